"""Any recording a client sends → 16 kHz mono signed 16-bit PCM, decoded with PyAV (FFmpeg
bundled in the wheel; no ffmpeg on the machine needed).

The browser's MediaRecorder sends ``audio/webm;codecs=opus`` (Chromium, Firefox) or
``audio/mp4`` (Safari); other clients send WAV or Ogg/Opus. A content type outside
:data:`SUPPORTED` is :class:`UnsupportedAudio` (HTTP 415); a body FFmpeg cannot read as that
kind of audio is :class:`CorruptAudio` (HTTP 422).
"""

from __future__ import annotations

import io
from dataclasses import dataclass

import av
import numpy as np
from av.error import FFmpegError

RATE = 16_000
#: content types (without parameters) → FFmpeg's container format for them
SUPPORTED = {
    "audio/webm": "webm",
    "audio/ogg": "ogg",
    "audio/opus": "ogg",
    "audio/wav": "wav",
    "audio/wave": "wav",
    "audio/x-wav": "wav",
    "audio/vnd.wave": "wav",
    "audio/mp4": "mp4",
    "audio/x-m4a": "mp4",
    "audio/m4a": "mp4",
    "audio/aac": "aac",
    "audio/mpeg": "mp3",
    "audio/flac": "flac",
}
MAX_SECONDS = 60.0  # longer recordings are refused (a push-to-talk turn is a sentence)


class AudioFormatError(ValueError):
    """The body is not audio this brain can read."""


class UnsupportedAudio(AudioFormatError):
    """The content type is not one of :data:`SUPPORTED` (HTTP 415)."""


class CorruptAudio(AudioFormatError):
    """The body is not readable as its content type says (HTTP 422)."""


@dataclass(frozen=True)
class Utterance:
    """One utterance: what the client sent and its 16 kHz mono PCM."""

    audio: bytes
    mime_type: str
    pcm: np.ndarray  # int16, mono, RATE Hz

    @property
    def seconds(self) -> float:
        return len(self.pcm) / RATE

    @classmethod
    def from_pcm(cls, pcm: np.ndarray) -> Utterance:
        """Already 16 kHz mono (the microphone node's utterances): a WAV is made for engines
        that want a file."""
        samples = np.asarray(pcm, dtype=np.int16)
        return cls(wav_bytes(samples), "audio/wav", samples)


MIN_PEAK = 300  # an utterance quieter than this (int16 peak) is nothing heard


def nothing_said(samples: np.ndarray) -> bool:
    """No sample of the 16-bit recording reaches ``MIN_PEAK``: silence, not speech."""
    return samples.size == 0 or int(np.abs(samples.astype(np.int32)).max()) < MIN_PEAK


def base_type(mime_type: str) -> str:
    return mime_type.split(";", 1)[0].strip().lower()


def decode(audio: bytes, mime_type: str) -> Utterance:
    """Decode and resample to :data:`RATE` Hz mono int16; raises :class:`AudioFormatError`."""
    kind = base_type(mime_type)
    container_format = SUPPORTED.get(kind)
    if container_format is None:
        known = ", ".join(sorted(SUPPORTED))
        raise UnsupportedAudio(
            f"audio type {kind or '(none)'!r} is not supported; send one of {known}"
        )
    try:
        pcm = _decode(audio, container_format)
    except (FFmpegError, ValueError, IndexError, EOFError) as exc:
        raise CorruptAudio(f"the body could not be decoded as {kind}: {exc}") from exc
    if pcm.size == 0:
        raise CorruptAudio(f"the body holds no audio samples ({kind})")
    if pcm.size > MAX_SECONDS * RATE:
        raise CorruptAudio(f"the recording is longer than {MAX_SECONDS:.0f} s")
    return Utterance(audio, kind, pcm)


def _decode(audio: bytes, container_format: str) -> np.ndarray:
    resampler = av.AudioResampler(format="s16", layout="mono", rate=RATE)
    chunks: list[np.ndarray] = []
    with av.open(io.BytesIO(audio), mode="r", format=container_format) as container:
        if not container.streams.audio:
            raise ValueError("no audio stream")
        stream = container.streams.audio[0]
        for frame in container.decode(stream):
            for out in resampler.resample(frame):
                chunks.append(out.to_ndarray().reshape(-1))
            if sum(c.size for c in chunks) > MAX_SECONDS * RATE:
                break
    for out in resampler.resample(None):
        chunks.append(out.to_ndarray().reshape(-1))
    return np.concatenate(chunks).astype(np.int16) if chunks else np.zeros(0, np.int16)


def wav_bytes(pcm: np.ndarray, rate: int = RATE) -> bytes:
    """16-bit mono WAV of ``pcm``."""
    import wave

    buffer = io.BytesIO()
    with wave.open(buffer, "wb") as out:
        out.setnchannels(1)
        out.setsampwidth(2)
        out.setframerate(rate)
        out.writeframes(np.asarray(pcm, dtype="<i2").tobytes())
    return buffer.getvalue()


def encode(pcm: np.ndarray, container_format: str, codec: str, rate: int = 48_000) -> bytes:
    """``pcm`` (16 kHz mono int16) encoded as ``codec`` in ``container_format`` — what a browser
    or phone would send (tests, benchmarks, robot-sim)."""
    buffer = io.BytesIO()
    with av.open(buffer, mode="w", format=container_format) as container:
        stream = container.add_stream(codec, rate=rate, layout="mono")
        assert isinstance(stream, av.AudioStream)
        resampler = av.AudioResampler(format=stream.format.name, layout="mono", rate=rate)
        frame = av.AudioFrame.from_ndarray(
            np.asarray(pcm, dtype=np.int16).reshape(1, -1), format="s16", layout="mono"
        )
        frame.sample_rate = RATE
        for resampled in [*resampler.resample(frame), *resampler.resample(None)]:
            for packet in stream.encode(resampled):
                container.mux(packet)
        for packet in stream.encode(None):
            container.mux(packet)
    return buffer.getvalue()
