"""Speech ports: output (say / streamed say / interrupt) and input (transcription)."""

from __future__ import annotations

import abc
import re
from collections.abc import AsyncIterator

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


class TranscriptionError(RuntimeError):
    """Audio could not be transcribed (bad input or provider failure)."""


class SpeechInput(abc.ABC):
    """Port: audio bytes of one user utterance → text."""

    #: False for the placeholder adapter: the UI disables its microphone and says why.
    configured: bool = True

    @abc.abstractmethod
    async def transcribe(self, audio: bytes, mime_type: str) -> str: ...
