"""The free-form on-board engine: faster-whisper (MIT) on CTranslate2 with a model folder the
owner provides (``WHISPER_MODEL``: a CTranslate2 Whisper conversion — ``model.bin`` beside
``tokenizer.json``). Loaded with ``local_files_only``: nothing is downloaded, ever (without
``tokenizer.json`` faster-whisper would fetch one from the Hub, so such a folder is refused).

It hears anything, so its words are scored before they are believed. **Confidence** is the
geometric mean of the probabilities of the tokens it wrote: ``exp`` of the segments'
``avg_logprob`` weighted by their token counts (durations are no weight here: without
timestamps a segment spans the whole 30 s window). ``exp(-0.36) ≈ 0.7``: Whisper's own
"failed decode" line, ``avg_logprob < -1``, is ≈ 0.37. When the model says nobody spoke
(``no_speech_prob`` above ``no_speech_above``, token-weighted too) the confidence is 0 and the
hearing is ``nothing_heard``. Below ``reject_below`` → ``low_confidence``, except a stop (a stop
heard by mistake is never wrong); a motion command below ``confirm_below`` is read back before
the robot moves. The thresholds are a starting point, not a calibration: no real Whisper model
was measured here (the tests use random weights).

Decoding: English, greedy or a small beam, one temperature (the fallback ladder re-decodes at
higher temperatures: slower, and a sampled guess is no command), no VAD (the microphone node
already cut the utterance), no conditioning on earlier text, no timestamps.
``prompt_with_vocabulary`` passes the live place and object names as ``hotwords``; off by
default — a prompt makes Whisper more likely to write those words into noise.
"""

from __future__ import annotations

import asyncio
import importlib.util
import math
import threading
import time
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any, Protocol

import numpy as np
import structlog

from robot_voice_chat.services.speech.audio import RATE, Utterance, nothing_said
from robot_voice_chat.services.speech.base import (
    Heard,
    HearingSpeechInput,
    Rejection,
    TranscriptionError,
)
from robot_voice_chat.services.speech.vocabulary import (
    DEFAULT_OBJECTS,
    Vocabulary,
    kind_of,
)

logger = structlog.get_logger(__name__)

#: what a CTranslate2 Whisper folder needs for faster-whisper to load it without the network
MODEL_FILES = ("model.bin", "tokenizer.json")
INSTALL_HINT = "uv sync --extra whisper (or scripts/install-model-libs.sh)"
COMPUTE_TYPES = ("int8", "int8_float32", "float32", "int8_float16", "float16")


class Segment(Protocol):
    """What faster-whisper says of one segment (the fields the confidence reads)."""

    text: str
    tokens: list[int]
    avg_logprob: float
    no_speech_prob: float


def confidence_of(segments: Sequence[Segment], no_speech_above: float) -> tuple[float, bool]:
    """(confidence 0..1, nobody spoke) from the segments: see the module docstring."""
    weights = [max(len(s.tokens), 1) for s in segments]
    total = sum(weights)
    if not total:
        return 0.0, True
    no_speech = sum(w * s.no_speech_prob for w, s in zip(weights, segments, strict=True)) / total
    if no_speech > no_speech_above:
        return 0.0, True
    logprob = sum(w * s.avg_logprob for w, s in zip(weights, segments, strict=True)) / total
    return float(min(1.0, max(0.0, math.exp(logprob)))), False


def missing_model_files(folder: Path) -> str | None:
    """Why ``folder`` is not a faster-whisper model (None: it looks like one)."""
    if not folder.is_dir():
        return f"WHISPER_MODEL folder {folder} does not exist"
    missing = [name for name in MODEL_FILES if not (folder / name).is_file()]
    if not missing:
        return None
    hint = ""
    if any((folder / n).is_file() for n in ("model.safetensors", "pytorch_model.bin")):
        hint = " (a transformers checkpoint: convert it with ct2-transformers-converter)"
    return (
        f"WHISPER_MODEL folder {folder} is not a CTranslate2 Whisper model: "
        f"no {' or '.join(missing)}{hint}"
    )


class FasterWhisperSpeechInput(HearingSpeechInput):
    """``speech_input: whisper`` — see the module docstring."""

    name = "on-board transcription (faster-whisper)"

    def __init__(
        self,
        model_dir: str = "",
        device: str = "cpu",
        compute_type: str = "int8",
        beam_size: int = 1,
        cpu_threads: int = 0,
        reject_below: float = 0.3,
        confirm_below: float = 0.7,
        no_speech_above: float = 0.6,
        prompt_with_vocabulary: bool = False,
        objects: Iterable[str] = DEFAULT_OBJECTS,
        required: bool = True,
    ) -> None:
        """``required: false`` (a chain's first member): no folder → not configured, and the
        chain uses the next engine, instead of refusing to start."""
        if not 0.0 <= reject_below <= confirm_below <= 1.0:
            raise ValueError("need 0 <= reject_below <= confirm_below <= 1")
        if not 1 <= beam_size <= 5:
            raise ValueError(f"whisper beam_size must be 1..5, not {beam_size}")
        if compute_type not in COMPUTE_TYPES:
            raise ValueError(f"whisper compute_type must be one of {', '.join(COMPUTE_TYPES)}")
        self.reject_below, self.confirm_below = reject_below, confirm_below
        self.no_speech_above, self.beam_size = no_speech_above, beam_size
        self.prompt_with_vocabulary = prompt_with_vocabulary
        self._objects = tuple(objects)  # the site's object labels (hotwords with the places)
        self._vocabulary = Vocabulary.build([], self._objects)
        self._hotwords = ""
        self._lock = threading.Lock()
        self._model: Any = None
        self.load_s = 0.0
        if not model_dir.strip():
            if required:
                raise ValueError(
                    "WHISPER_MODEL is empty but the whisper speech_input is selected: set it to "
                    "a faster-whisper (CTranslate2) model folder"
                )
            self.configured = False
            return
        # checked before the import so the one line names the extra, not a bare module name
        if importlib.util.find_spec("faster_whisper") is None:
            raise ValueError(f"speech_input whisper needs faster-whisper: {INSTALL_HINT}")
        folder = Path(model_dir).expanduser()
        problem = missing_model_files(folder)
        if problem:
            raise ValueError(problem)
        self._model = self._load(folder, device, compute_type, cpu_threads)

    def _load(self, folder: Path, device: str, compute_type: str, cpu_threads: int) -> Any:
        from faster_whisper import (  # type: ignore[import-untyped,import-not-found,unused-ignore]  # MIT
            WhisperModel,
        )

        started = time.monotonic()
        try:
            model = WhisperModel(
                str(folder),
                device=device,
                compute_type=compute_type,
                cpu_threads=cpu_threads,
                local_files_only=True,
            )
        except (RuntimeError, ValueError, OSError) as exc:
            reason = " ".join(str(exc).split())
            raise ValueError(f"cannot load the faster-whisper model in {folder}: {reason}") from exc
        self.load_s = time.monotonic() - started
        logger.info(
            "speech_whisper_loaded",
            load_ms=round(self.load_s * 1000, 1),
            model=str(folder),
            device=device,
            compute_type=compute_type,
        )
        return model

    @property
    def vocabulary(self) -> Vocabulary:
        return self._vocabulary

    def update_vocabulary(
        self, places: Iterable[Iterable[str]], objects: Iterable[str] = (), wake: str = ""
    ) -> bool:
        """Kept to tell motion from other words (and, with ``prompt_with_vocabulary``, as
        hotwords); True only when the hotwords changed."""
        vocabulary = self._vocabulary.with_live(places, self._objects, objects, wake)
        self._vocabulary = vocabulary
        if not self.prompt_with_vocabulary:
            return False
        hotwords = ", ".join([*vocabulary.place_phrases(), *vocabulary.objects])
        changed, self._hotwords = hotwords != self._hotwords, hotwords
        return changed

    async def hear(self, utterance: Utterance) -> Heard:
        return await asyncio.to_thread(self.hear_pcm, utterance.pcm)

    def hear_pcm(self, pcm: np.ndarray) -> Heard:
        """Transcribe 16 kHz mono int16 audio (blocking; ``hear`` runs it in a thread)."""
        if self._model is None:
            raise TranscriptionError("the whisper speech input has no model (WHISPER_MODEL unset)")
        started = time.monotonic()
        samples = np.asarray(pcm, dtype=np.int16)
        if nothing_said(samples):
            return Heard("", 0.0, self.name, "other", rejected="nothing_heard")
        try:
            with self._lock:
                found, _info = self._model.transcribe(
                    samples.astype(np.float32) / 32768.0, **self._options()
                )
                segments = list(found)  # the generator decodes as it is read
        except (RuntimeError, ValueError) as exc:
            raise TranscriptionError(f"faster-whisper failed: {exc}") from exc
        text = " ".join(" ".join(s.text for s in segments).split())
        confidence, silent = confidence_of(segments, self.no_speech_above)
        kind = kind_of(text, self._vocabulary) if text else "other"
        rejected: Rejection | None = None
        if kind != "stop":  # a stop is acted on however unsure: never a wrong stop
            if not text or silent:
                rejected, confidence = "nothing_heard", 0.0
            elif confidence < self.reject_below:
                rejected = "low_confidence"
        heard = Heard(
            text,
            round(confidence, 3),
            self.name,
            kind,
            rejected=rejected,
            confirm=rejected is None and kind == "motion" and confidence < self.confirm_below,
        )
        logger.info(
            "speech_heard",
            engine="whisper",
            text=text,
            confidence=heard.confidence,
            kind=kind,
            rejected=rejected,
            segments=len(segments),
            duration_ms=round((time.monotonic() - started) * 1000, 1),
            audio_s=round(samples.size / RATE, 2),
        )
        return heard

    def _options(self) -> dict[str, Any]:
        return {
            "language": "en",
            "beam_size": self.beam_size,
            "temperature": 0.0,
            "vad_filter": False,
            "condition_on_previous_text": False,
            "without_timestamps": True,
            "hotwords": self._hotwords or None,
        }

    async def aclose(self) -> None:
        """Frees the model (CTranslate2 releases its weights when the last reference goes)."""
        with self._lock:
            self._model = None
