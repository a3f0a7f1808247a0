"""Fake speech adapters that record what they were asked to do."""

from __future__ import annotations

from robot_voice_chat.robot_words import witness
from robot_voice_chat.services.speech.base import SpeechInput, SpeechOutput


class FakeSpeechOutput(SpeechOutput):
    def __init__(self) -> None:
        self.spoken: list[str] = []
        self.interrupts = 0

    async def speak_sentence(self, sentence: str) -> None:
        self.spoken.append(sentence)
        witness([sentence])

    async def interrupt(self) -> None:
        self.interrupts += 1


class FakeSpeechInput(SpeechInput):
    def __init__(self, text: str = "hello") -> None:
        self.text = text
        self.received: list[tuple[bytes, str]] = []

    async def transcribe(self, audio: bytes, mime_type: str) -> str:
        self.received.append((audio, mime_type))
        return self.text
