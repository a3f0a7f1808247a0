"""Speech output spoken by the browser: one ``speak`` event per sentence."""

from __future__ import annotations

import uuid

from robot_voice_chat.services.emitter.base import EventEmitter
from robot_voice_chat.services.speech.base import SpeechOutput
from robot_voice_chat.socket_events import Speak, SpeechInterrupted


class SocketIOSpeechOutput(SpeechOutput):
    """The browser keeps the queue; ``interrupt`` tells it to drop it."""

    in_browser = True

    def __init__(self, emitter: EventEmitter) -> None:
        self._emitter = emitter

    async def speak_sentence(self, sentence: str) -> None:
        await self._emitter.emit(Speak(utterance_id=uuid.uuid4().hex[:8], text=sentence))

    async def interrupt(self) -> None:
        await self._emitter.emit(SpeechInterrupted())
