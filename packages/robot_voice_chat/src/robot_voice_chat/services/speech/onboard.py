"""The on-board recognizer: pocketsphinx 5.1.1 (BSD-2; its US-English acoustic model and
dictionary ship inside the wheel) with a JSGF grammar made from the live vocabulary
(``vocabulary.py``). No key, nothing downloaded, ~0.5 s to load.

A grammar recognizer always answers with a sentence of its grammar, so each hypothesis is
scored before it is believed:

* **a whole sentence** — the search returns its best *partial* path when the audio never
  reached the end of a sentence ("find the scissors in the"): not a sentence → rejected
  (``out_of_vocabulary``);
* **acoustic fit against a free phone loop** — the same audio is decoded again with the
  model's phone recognizer (any sound, no words); speech the grammar covers scores nearly as
  well with the grammar as with the phones, speech outside it much worse. Two measures: per
  frame over the utterance, and the worst word (a word the person never said). Both are
  mapped onto 0..1 and the lower one is the confidence. Below ``reject_below`` → rejected
  (``low_confidence``), except a stop (a stop heard by mistake is never wrong); the spoken
  layer reads a motion command back when it is below ``confirm_below`` ("Did you say: go to
  the kitchen?").

The searches run without the word-lattice pass (``bestpath``): it cost ~450 ms an utterance,
the grammar's scores then came in other units than the phone loop's (the loop looked like a
perfect fit, ≈ 1.0, so the comparison measured nothing) and more utterances ended on a
partial sentence.

The calibration (the two ``*_SPAN`` pairs, ``STOP_FIT``) was measured on the benchmark's
``tuning`` split (espeak-ng voices, clean and with pink noise) plus out-of-vocabulary
sentences and noise; ``benchmarks/speech_onboard.py`` scores it on held-out splits.
"""

from __future__ import annotations

import asyncio
import math
import threading
import time
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np
import structlog

from robot_voice_chat.services.speech.audio import MIN_PEAK, RATE, Utterance, nothing_said
from robot_voice_chat.services.speech.base import (
    Heard,
    HearingSpeechInput,
    Rejection,
)
from robot_voice_chat.services.speech.vocabulary import (
    DEFAULT_OBJECTS,
    Vocabulary,
    is_sentence,
    jsgf,
    kind_of,
    matcher,
    rules,
    words_of,
)

logger = structlog.get_logger(__name__)

GRAMMAR, PHONES, STOP = "grammar", "phones", "stop"
STOP_WORDS = ("stop", "halt", "freeze", "stop right now", "stop stop")
STOP_MAX_S = 1.2  # an utterance this short is also tried against the stop words alone
STOP_FIT = -2.0  # ... and is a stop when they fit it this well (per frame, vs the phone loop)
STOP_MARGIN = 0.5  # ... and this much better than the full grammar's hypothesis
# ... but over a sure hypothesis only these win ("halt" is what the stop words fit to "no",
# "hello", "go home" ...)
SURE_STOP_WORDS = ("stop", "stop stop", "stop right now", "freeze")
STOP_GUESS_WORDS = 2  # a hypothesis this short ("drop it") is checked against them even if sure
# log-likelihood per frame (grammar − phone loop) mapped onto 0..1: (low, high)
FRAME_SPAN = (-4.5, 0.0)
# the worst word's log-likelihood per frame against the phone loop, mapped onto 0..1
WORD_SPAN = (-9.5, -3.0)
# the binding hands a score as a probability of the score shifted right by 10 bits (the
# decoder's senone-score shift); multiplied back, the log-likelihoods are per frame in the
# decoder's own scale (a right word fits ~-5, a word never said ~-10 against the loop)
SCORE_SHIFT = 1024.0
TRIM_KEEP_S = 0.3  # kept around the speech when the recording's silence is cut
PAD_S = 0.3  # silence added at each end: the search needs to start and end in silence
DITHER = 8.0  # std of the noise added (int16 units): digital silence breaks the features


def _span(value: float, span: tuple[float, float]) -> float:
    low, high = span
    return float(min(1.0, max(0.0, (value - low) / (high - low))))


class PocketsphinxSpeechInput(HearingSpeechInput):
    """``speech_input: onboard`` — see the module docstring."""

    name = "on-board recognizer (pocketsphinx)"

    def __init__(
        self,
        objects: Iterable[str] = DEFAULT_OBJECTS,
        intents_files: Iterable[str] = (),
        reject_below: float = 0.25,
        confirm_below: float = 0.6,
        model_dir: str = "",
        search: dict[str, Any] | None = None,
    ) -> None:
        from pocketsphinx import (  # type: ignore[import-untyped]  # BSD-2, model in the wheel
            Config,
            Decoder,
            get_model_path,
        )

        if not 0.0 <= reject_below <= confirm_below <= 1.0:
            raise ValueError("need 0 <= reject_below <= confirm_below <= 1")
        self.reject_below, self.confirm_below = reject_below, confirm_below
        self._objects = tuple(objects)
        self._intents_files = [Path(p) for p in intents_files if p]
        root = Path(model_dir) if model_dir else Path(get_model_path()) / "en-us"
        if not (root / "en-us").is_dir():
            raise ValueError(f"pocketsphinx model folder {root} has no en-us acoustic model")
        config = Config(
            hmm=str(root / "en-us"),
            dict=str(root / "cmudict-en-us.dict"),
            lm=None,
            loglevel="FATAL",
            samprate=RATE,
            **{"bestpath": False, **(search or {})},
        )
        started = time.monotonic()
        self._decoder: Any = Decoder(config)
        self._decoder.add_allphone_file(PHONES, str(root / "en-us-phone.lm.bin"))
        stop = " | ".join(STOP_WORDS)
        self._decoder.add_jsgf_string(
            STOP, f"#JSGF V1.0;\ngrammar stop;\npublic <stop> = {stop};\n"
        )
        self.load_s = time.monotonic() - started
        self._lock = threading.Lock()
        self._digest = ""
        self._vocabulary = self._initial_vocabulary()
        self._install(self._vocabulary)
        logger.info("speech_onboard_loaded", load_ms=round(self.load_s * 1000, 1), model=str(root))

    def _initial_vocabulary(self) -> Vocabulary:
        from robot_language.intents import load_intents

        return Vocabulary.build([], self._objects, load_intents(self._intents_files))

    @property
    def vocabulary(self) -> Vocabulary:
        return self._vocabulary

    def update_vocabulary(
        self, places: Iterable[Iterable[str]], objects: Iterable[str] = (), wake: str = ""
    ) -> bool:
        """The live places (spoken names per place) and any object labels heard of beyond
        the configured ones; the grammar is rebuilt when anything changed (True)."""
        vocabulary = self._vocabulary.with_live(places, self._objects, objects, wake)
        if vocabulary.digest() == self._digest:
            return False
        self._install(vocabulary)
        return True

    # --- the grammar ---------------------------------------------------------------------
    def _install(self, vocabulary: Vocabulary) -> None:
        with self._lock:
            dropped = self._teach_words(vocabulary)
            grammar = rules(vocabulary, self._known)
            self._decoder.add_jsgf_string(GRAMMAR, jsgf(grammar))
            self._matcher = matcher(grammar)
            self._vocabulary, self._digest = vocabulary, vocabulary.digest()
        logger.info(
            "speech_grammar_built",
            places=len(vocabulary.places),
            objects=len(vocabulary.objects),
            unpronounceable=sorted(dropped)[:20],
        )

    def _known(self, word: str) -> bool:
        return self._decoder.lookup_word(word) is not None

    def _teach_words(self, vocabulary: Vocabulary) -> set[str]:
        """Pronunciations for words the dictionary lacks, when they are made of words it has
        ("mailroom" = mail + room, "harbour's" = harbour + z); the rest are returned (phrases
        with them are left out of the grammar)."""
        wanted = {w for p in vocabulary.place_phrases() for w in p.split()}
        wanted |= {w for o in vocabulary.objects for w in o.split()}
        wanted |= set(vocabulary.wake.split())
        missing = set()
        for word in sorted(wanted):
            if self._known(word):
                continue
            phones = self._compose(word)
            if phones:
                self._decoder.add_word(word, phones, True)
            else:
                missing.add(word)
        return missing

    def _compose(self, word: str) -> str | None:
        lookup = self._decoder.lookup_word
        if word.endswith("'s") and lookup(word[:-2]):
            return f"{lookup(word[:-2])} Z"
        for cut in range(2, len(word) - 1):
            head, tail = lookup(word[:cut]), lookup(word[cut:])
            if head and tail:
                return f"{head} {tail}"
        british = word.replace("our", "or") if "our" in word else None
        return lookup(british) if british else None

    # --- hearing -----------------------------------------------------------------------------
    async def hear(self, utterance: Utterance) -> Heard:
        return await asyncio.to_thread(self.hear_pcm, utterance.pcm)

    def hear_pcm(self, pcm: np.ndarray) -> Heard:
        """Recognize 16 kHz mono int16 audio (blocking; ``hear`` runs it in a thread)."""
        started = time.monotonic()
        samples = np.asarray(pcm, dtype=np.int16)
        if nothing_said(samples):
            return Heard("", 0.0, self.name, "other", rejected="nothing_heard")
        with self._lock:
            prepared = self._prepare(samples)
            text, grammar_ll, words = self._decode(GRAMMAR, prepared)
            _, phone_ll, phones = self._decode(PHONES, prepared)
            frames = max(int(self._decoder.n_frames()), 1)
            sentence = text is not None and is_sentence(text, self._matcher)
            vocabulary = self._vocabulary
            frame_fit = (grammar_ll - phone_ll) / frames
            worst = min((self._word_fit(w, phones) for w in words), default=-99.0)
            confidence = min(_span(frame_fit, FRAME_SPAN), _span(worst, WORD_SPAN))
            kind = kind_of(text, vocabulary) if text else "other"
            stop: tuple[str, float] | None = None
            if samples.size <= STOP_MAX_S * RATE and kind != "stop":
                unsure = not sentence or confidence < self.reject_below
                few = len(words_of(text or "")) <= STOP_GUESS_WORDS and kind != "answer"
                if unsure or few:
                    beat = frame_fit + STOP_MARGIN if sentence else -math.inf
                    allowed = STOP_WORDS if unsure else SURE_STOP_WORDS
                    stop = self._stop_instead(prepared, phone_ll, frames, beat, allowed)
        if stop is not None:
            logger.info(
                "speech_heard", engine="onboard", text=stop[0], kind="stop", by="stop_words"
            )
            return Heard(stop[0], round(stop[1], 3), self.name, "stop")
        text = " ".join(w for w in words_of(text or ""))
        rejected: Rejection | None = None
        if not sentence:
            rejected, confidence = "out_of_vocabulary", 0.0
        elif confidence < self.reject_below and kind != "stop":
            # a stop is acted on however unsure: a stop heard by mistake is never wrong
            rejected = "low_confidence"
        heard = Heard(
            text,
            round(confidence, 3),
            self.name,
            kind,
            rejected=rejected,
            confirm=rejected is None and confidence < self.confirm_below,
        )
        logger.info(
            "speech_heard",
            engine="onboard",
            text=text,
            confidence=heard.confidence,
            kind=heard.kind,
            rejected=rejected,
            frame_fit=round(frame_fit, 2),
            worst_word=round(worst, 2),
            duration_ms=round((time.monotonic() - started) * 1000, 1),
            audio_s=round(samples.size / RATE, 2),
        )
        return heard

    def _stop_instead(
        self, prepared: bytes, phone_ll: float, frames: int, beat: float, allowed: tuple[str, ...]
    ) -> tuple[str, float] | None:
        """The stop words alone, for a short utterance the grammar heard no sure sentence in,
        or only a word or two that are neither a stop nor a yes/no: a fast "stop" it may have
        heard as "drop it". A false stop is safe, but the stop words must fit well and better
        than ``beat`` (the grammar's sentence, by a margin; -inf when it found none: the other
        answer is then a rejection)."""
        said, stop_ll, _ = self._decode(STOP, prepared)
        fit = (stop_ll - phone_ll) / frames
        if said in allowed and fit >= max(STOP_FIT, beat):
            return said, _span(fit, FRAME_SPAN)
        return None

    def _prepare(self, samples: np.ndarray) -> bytes:
        pad = np.zeros(int(PAD_S * RATE), dtype=np.float64)
        signal = np.concatenate([pad, trim(samples).astype(np.float64), pad])
        signal += np.random.default_rng(0).standard_normal(signal.size) * DITHER  # repeatable
        return bytes(np.clip(signal, -32768, 32767).astype(np.int16).tobytes())

    def _decode(
        self, search: str, audio: bytes
    ) -> tuple[str | None, float, list[tuple[str, float, int, int]]]:
        decoder = self._decoder
        decoder.activate_search(search)
        decoder.start_utt()
        decoder.process_raw(audio, False, True)
        decoder.end_utt()
        hyp = decoder.hyp()
        segments = [
            (seg.word, _log(seg.ascore), int(seg.start_frame), int(seg.end_frame))
            for seg in (decoder.seg() or [])
        ]
        total = sum(score for _, score, _, _ in segments)
        return (hyp.hypstr if hyp is not None else None), total, segments

    @staticmethod
    def _word_fit(
        word: tuple[str, float, int, int], phones: list[tuple[str, float, int, int]]
    ) -> float:
        """A spoken word's log-likelihood per frame against the phone loop over its frames
        (silences, sentence marks and empty transitions are not words: they fit anything)."""
        name, score, start, end = word
        if name.startswith(("<", "[", "(")):  # (NULL): a grammar's empty transition
            return 0.0
        over = sum(s for _, s, a, b in phones if a >= start and b <= end + 1)
        return (score - over) / max(end - start + 1, 1)


def trim(samples: np.ndarray) -> np.ndarray:
    """The utterance without the silence a recording has before and after the speech (a held
    push-to-talk button, a microphone's pauses): long silence shifts the recognizer's cepstral
    mean and it then hears nothing. Frames of 20 ms louder than 10 % of the loudest frame's RMS
    are speech; 300 ms are kept around them."""
    frame = RATE // 50
    count = samples.size // frame
    if count < 3:
        return samples
    frames = samples[: count * frame].astype(np.float64).reshape(count, frame)
    rms = np.sqrt(np.mean(frames**2, axis=1))
    loud = np.flatnonzero(rms >= max(0.1 * float(rms.max()), MIN_PEAK / 10))
    if loud.size == 0:
        return samples
    keep = int(TRIM_KEEP_S * RATE)
    start = max(0, int(loud[0]) * frame - keep)
    end = min(samples.size, (int(loud[-1]) + 1) * frame + keep)
    return samples[start:end]


def _log(value: float) -> float:
    """A score the binding handed as a probability, back on the decoder's log scale (see
    ``SCORE_SHIFT``); one that underflowed is the smallest log."""
    return (math.log(value) if value > 0 else -745.0) * SCORE_SHIFT


def model_path() -> str:
    """The shipped model's folder (benchmarks print it)."""
    from pocketsphinx import get_model_path

    return str(Path(get_model_path()) / "en-us")
