"""On-board recognizer (issue 36): a spoken set scored end to end — espeak-ng voices, clean and
with pink noise (10 dB SNR) → the on-board recognizer (pocketsphinx + the live-vocabulary
grammar, the office's places) → the spoken layer's decision → the understanding layer's
reading of what was heard, compared with what the typed sentence means.

    uv run --frozen python benchmarks/speech_onboard.py [--split tuning,held_out,held_out_c]
        [--voices a,b,c,d] [--limit N]

Outcomes per utterance: ``done`` (heard, acted on at once, and it does what the typed sentence
does), ``asked`` (read back "Did you say: …?"; ``asked_right`` when the read-back is what was
meant), ``rejected`` ("I didn't catch that"), ``other`` (heard and not acted on: the
understanding layer asked or refused), ``wrong`` (acted on at once with a motion the typed
sentence does not ask for — must be 0). Also: transcription latency p50/p99 per utterance,
model load time, grammar build time, and ``exact``: transcripts that are the words said.

The set: ``speech_onboard_set.yaml``, written before any tuning, in two splits — ``tuning``
(every third sentence of the understanding layer's ``set_a.yaml``, the first 16: helper V's
first run scored these, so changes are tuned on them only) and ``held_out`` (every fifth of
``set_b.yaml``, the first 10: never tuned on), and ``held_out_c`` (added 2026-11-29 before the
recall work, never tuned on: every third of ``set_c.yaml``'s sentences whose objects the
recognizer knows). Each sentence is said by every voice, clean and noisy; the JSON reports each
split apart. ``--limit N``: the first N sentences of each split (to iterate quickly).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import time
from pathlib import Path

import yaml

from robot_language.scoring import (
    OFFICE_LIST_LOCATIONS,
    acts,
    is_wrong,
)
from robot_language.understand import Understanding
from robot_voice_chat.services.speech.onboard import PocketsphinxSpeechInput
from robot_voice_chat.services.speech.synth import say, with_noise
from robot_voice_chat.services.speech.vocabulary import places_from_listing, words_of

SET = Path(__file__).parent / "speech_onboard_set.yaml"
RESULTS = Path(__file__).parent / "results" / "speech_onboard.json"
VOICES = ("en-us", "en-gb-scotland", "en-us+f3", "en-029")
OUTCOMES = ("done", "asked", "asked_right", "rejected", "other", "wrong")


def spoken_set(split: str) -> list[tuple[str, list[str]]]:
    data = yaml.safe_load(SET.read_text())
    return [(str(text), [str(e) for e in expected]) for text, expected in data[split]]


def percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(q * len(ordered)))] if ordered else 0.0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--split", default="tuning,held_out,held_out_c", help="splits")
    parser.add_argument("--limit", type=int, default=0, help="first N sentences per split")
    parser.add_argument("--voices", default=",".join(VOICES))
    parser.add_argument("--out", type=Path, default=RESULTS, help="the JSON written")
    args = parser.parse_args()
    voices = args.voices.split(",")

    started = time.monotonic()
    recognizer = PocketsphinxSpeechInput()
    load_s = time.monotonic() - started
    started = time.monotonic()
    recognizer.update_vocabulary(places_from_listing(OFFICE_LIST_LOCATIONS))
    grammar_s = time.monotonic() - started
    understanding = Understanding()
    places = understanding.places(OFFICE_LIST_LOCATIONS)

    rows: list[dict[str, object]] = []
    splits: dict[str, dict[str, object]] = {}
    all_latencies: list[float] = []
    for split in args.split.split(","):
        counts = dict.fromkeys(OUTCOMES, 0)
        exact = 0  # transcripts that are what was said (words, case and punctuation aside)
        latencies: list[float] = []
        for text, expected in spoken_set(split)[: args.limit or None]:
            for voice in voices:
                for noisy in (False, True):
                    pcm = say(text, voice)
                    if noisy:
                        pcm = with_noise(pcm, 10.0, seed=len(rows))
                    t0 = time.monotonic()
                    heard = recognizer.hear_pcm(pcm)
                    latencies.append(time.monotonic() - t0)
                    said = heard.text
                    exact += words_of(said) == words_of(text)
                    reading = understanding.understand(said, places).code() if said else []
                    right = reading == expected
                    if not heard.usable:
                        outcome = "rejected"
                    elif heard.confirm and heard.kind == "motion":
                        outcome = "asked"
                        counts["asked_right"] += right
                    elif right:
                        outcome = "done"
                    elif is_wrong(reading, expected) and acts(reading):
                        outcome = "wrong"
                    else:
                        outcome = "other"
                    counts[outcome] += 1
                    rows.append(
                        {
                            "split": split,
                            "said": text,
                            "voice": voice,
                            "noisy": noisy,
                            "heard": heard.text,
                            "confidence": heard.confidence,
                            "outcome": outcome,
                            "reading": reading,
                            "expected": expected,
                            "audio_s": round(len(pcm) / 16000, 2),
                            "latency_ms": round(1000 * latencies[-1], 1),
                        }
                    )
                    kind = "noisy" if noisy else "clean"
                    print(f"{split:8s} {outcome:8s} {voice:15s} {kind} {text!r} → {heard.text!r}")
        total = sum(1 for r in rows if r["split"] == split)
        all_latencies += latencies
        splits[split] = {
            "utterances": total,
            "exact": exact,
            **counts,
            "done_pct": round(100 * counts["done"] / max(total, 1), 1),
            "latency_ms_p50": round(1000 * statistics.median(latencies), 1),
            "latency_ms_p99": round(1000 * percentile(latencies, 0.99), 1),
        }
    summary = {
        "utterances": len(rows),
        "voices": voices,
        "tuned_on": "tuning",
        "held_out": "held_out, held_out_c (never tuned on)",
        "splits": splits,
        "wrong": sum(int(str(s["wrong"])) for s in splits.values()),
        "latency_ms_p50": round(1000 * statistics.median(all_latencies), 1),
        "latency_ms_p99": round(1000 * percentile(all_latencies, 0.99), 1),
        "model_load_ms": round(1000 * load_s, 1),
        "grammar_build_ms": round(1000 * grammar_s, 1),
        "load_average": os.getloadavg()[0],
    }
    print(json.dumps(summary, indent=2))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({"summary": summary, "rows": rows}, indent=2))


if __name__ == "__main__":
    main()
