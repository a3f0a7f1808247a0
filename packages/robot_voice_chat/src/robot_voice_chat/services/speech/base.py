"""Speech ports: output (say / streamed say / interrupt) and input (transcription)."""

from __future__ import annotations

import abc
import re
from collections.abc import AsyncIterator, Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal

if TYPE_CHECKING:
    from robot_voice_chat.services.speech.audio import Utterance

_SENTENCE_END = re.compile(r"(?<=[.!?…])\s+")


class SentenceChunker:
    """Cuts a stream of text deltas into whole sentences (the TTS unit)."""

    def __init__(self) -> None:
        self._buffer = ""

    def feed(self, delta: str) -> list[str]:
        self._buffer += delta
        parts = _SENTENCE_END.split(self._buffer)
        self._buffer = parts.pop()
        return [p.strip() for p in parts if p.strip()]

    def flush(self) -> list[str]:
        rest, self._buffer = self._buffer.strip(), ""
        return [rest] if rest else []


def split_sentences(text: str) -> list[str]:
    chunker = SentenceChunker()
    return chunker.feed(text) + chunker.flush()


class SpeechOutput(abc.ABC):
    """Port: speak text sentence by sentence; ``interrupt`` drops everything queued."""

    #: True when the browser does the talking (``speak`` events); the UI then speaks them.
    in_browser: bool = False

    @abc.abstractmethod
    async def speak_sentence(self, sentence: str) -> None:
        """Queue one sentence (never blocks until it is spoken)."""

    @abc.abstractmethod
    async def interrupt(self) -> None:
        """Stop the current sentence and drop queued speech (barge-in, §9)."""

    async def say(self, text: str) -> None:
        for sentence in split_sentences(text):
            await self.speak_sentence(sentence)

    async def say_stream(self, deltas: AsyncIterator[str]) -> str:
        """Speak a streamed reply as its sentences complete; returns the whole text."""
        chunker, parts = SentenceChunker(), []
        async for delta in deltas:
            parts.append(delta)
            for sentence in chunker.feed(delta):
                await self.speak_sentence(sentence)
        for sentence in chunker.flush():
            await self.speak_sentence(sentence)
        return "".join(parts)

    async def aclose(self) -> None:  # noqa: B027 - optional hook
        """Stop workers."""


Outage = Literal["network", "timeout", "server", "rate_limit", "auth"]


class TranscriptionError(RuntimeError):
    """Audio could not be transcribed (bad input or provider failure). ``outage`` names a
    provider outage another engine can answer for (None: the audio itself was refused)."""

    def __init__(self, message: str, outage: Outage | None = None) -> None:
        super().__init__(message)
        self.outage = outage


HeardKind = Literal["stop", "motion", "answer", "other"]
Rejection = Literal["out_of_vocabulary", "low_confidence", "nothing_heard"]


@dataclass(frozen=True)
class Heard:
    """What a recognizer made of one utterance.

    ``confidence`` is 0..1 (None: the engine gives none, e.g. a cloud transcriber);
    ``kind`` is what the words ask for (on-board: read from its grammar; a free-form engine
    says ``other``); ``rejected`` says why the words must not be acted on; ``confirm`` asks
    the spoken layer to read a motion command back before it moves; ``notice`` is one plain
    sentence to say once (a cloud outage and what answers instead)."""

    text: str
    confidence: float | None = None
    engine: str = ""
    kind: HeardKind = "other"
    rejected: Rejection | None = None
    confirm: bool = False
    notice: str | None = None

    @property
    def usable(self) -> bool:
        return self.rejected is None and bool(self.text.strip())


class SpeechInput(abc.ABC):
    """Port: audio of one user utterance → text (``transcribe``) or a scored hearing
    (``hear``)."""

    #: False for the placeholder adapter: the UI disables its microphone and says why.
    configured: bool = True
    #: what the status bar names ("on-board recognizer (pocketsphinx)")
    name: str = "speech input"

    @abc.abstractmethod
    async def transcribe(self, audio: bytes, mime_type: str) -> str: ...

    async def hear(self, utterance: Utterance) -> Heard:
        """Default: a free-form transcription, no confidence, acted on as it is."""
        text = (await self.transcribe(utterance.audio, utterance.mime_type)).strip()
        return Heard(text, None, self.name, rejected=None if text else "nothing_heard")

    def update_vocabulary(
        self, places: Iterable[Iterable[str]], objects: Iterable[str] = (), wake: str = ""
    ) -> bool:
        """The live places (spoken names per place), object labels and the site's wake
        phrase; True when the recognizer rebuilt what it listens for (free-form engines need
        none)."""
        return False

    async def aclose(self) -> None:  # noqa: B027 - optional hook
        """Release clients and models."""


class HearingSpeechInput(SpeechInput):
    """An engine that scores what it hears: ``transcribe`` is its hearing's usable text (an
    audio body it cannot decode is a :class:`TranscriptionError`)."""

    async def transcribe(self, audio: bytes, mime_type: str) -> str:
        from robot_voice_chat.services.speech.audio import AudioFormatError, decode

        try:
            utterance = decode(audio, mime_type)
        except AudioFormatError as exc:
            raise TranscriptionError(str(exc)) from exc
        heard = await self.hear(utterance)
        return heard.text if heard.usable else ""

    @abc.abstractmethod
    async def hear(self, utterance: Utterance) -> Heard: ...
