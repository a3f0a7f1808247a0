"""On-board recognizer (issue 36): a spoken set scored end to end — espeak-ng voices, clean and
with pink noise (10 dB SNR) → the on-board recognizer (pocketsphinx + the live-vocabulary
grammar, the office's places) → the spoken layer's decision → the understanding layer's
reading of what was heard, compared with what the typed sentence means.

    uv run --frozen python benchmarks/speech_onboard.py [--limit N] [--voices a,b,c,d]

Outcomes per utterance: ``done`` (heard, acted on at once, and it does what the typed sentence
does), ``asked`` (read back "Did you say: …?"; ``asked_right`` when the read-back is what was
meant), ``rejected`` ("I didn't catch that"), ``other`` (heard and not acted on: the
understanding layer asked or refused), ``wrong`` (acted on at once with a motion the typed
sentence does not ask for — must be 0). Also: transcription latency p50/p99 per utterance,
model load time, grammar build time.

The set: every third sentence of the understanding layer's ``set_a.yaml`` (written for issue
22, not for speech; the first 16 by default), each said by every voice, clean and noisy. It was
chosen before the recognizer's numbers were looked at and is not tuned on.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import time
from pathlib import Path

from robot_voice_chat.services.llm.understanding.scoring import (
    OFFICE_LIST_LOCATIONS,
    acts,
    is_wrong,
    load_set,
)
from robot_voice_chat.services.llm.understanding.understand import Understanding
from robot_voice_chat.services.speech.onboard import PocketsphinxSpeechInput
from robot_voice_chat.services.speech.synth import say, with_noise
from robot_voice_chat.services.speech.vocabulary import places_from_listing

DATA = Path(__file__).parents[1] / "packages/robot_voice_chat/tests/unit/understanding/data"
RESULTS = Path(__file__).parent / "results" / "speech_onboard.json"
VOICES = ("en-us", "en-gb-scotland", "en-us+f3", "en-029")


def spoken_set(limit: int) -> list[tuple[str, list[str]]]:
    return load_set(DATA / "set_a.yaml")[::3][:limit]


def percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(q * len(ordered)))] if ordered else 0.0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--limit", type=int, default=16, help="sentences of the set")
    parser.add_argument("--voices", default=",".join(VOICES))
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

    counts = {"done": 0, "asked": 0, "asked_right": 0, "rejected": 0, "other": 0, "wrong": 0}
    latencies: list[float] = []
    rows = []
    for text, expected in spoken_set(args.limit):
        for voice in voices:
            for noisy in (False, True):
                pcm = say(text, voice)
                if noisy:
                    pcm = with_noise(pcm, 10.0, seed=len(rows))
                t0 = time.monotonic()
                heard = recognizer.hear_pcm(pcm)
                latencies.append(time.monotonic() - t0)
                reading = understanding.understand(heard.text, places).code() if heard.text else []
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
                        "said": text,
                        "voice": voice,
                        "noisy": noisy,
                        "heard": heard.text,
                        "confidence": heard.confidence,
                        "outcome": outcome,
                        "reading": reading,
                        "expected": expected,
                        "audio_s": round(len(pcm) / 16000, 2),
                    }
                )
                kind = "noisy" if noisy else "clean"
                print(f"{outcome:8s} {voice:15s} {kind} {text!r} → {heard.text!r}")
    total = len(rows)
    summary = {
        "utterances": total,
        "sentences": args.limit,
        "voices": voices,
        **counts,
        "done_pct": round(100 * counts["done"] / max(total, 1), 1),
        "latency_ms_p50": round(1000 * statistics.median(latencies), 1),
        "latency_ms_p99": round(1000 * percentile(latencies, 0.99), 1),
        "model_load_ms": round(1000 * load_s, 1),
        "grammar_build_ms": round(1000 * grammar_s, 1),
        "load_average": os.getloadavg()[0],
    }
    print(json.dumps(summary, indent=2))
    RESULTS.parent.mkdir(parents=True, exist_ok=True)
    RESULTS.write_text(json.dumps({"summary": summary, "rows": rows}, indent=2))


if __name__ == "__main__":
    main()
