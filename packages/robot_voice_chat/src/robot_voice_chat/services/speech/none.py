"""The speech input of a brain without a transcription provider (``speech_input: none``)."""

from __future__ import annotations

from robot_voice_chat.services.speech.base import SpeechInput, TranscriptionError


class NoSpeechInput(SpeechInput):
    """Selected when no transcription provider is configured; says so clearly."""

    configured = False

    async def transcribe(self, audio: bytes, mime_type: str) -> str:
        raise TranscriptionError("no speech input configured (speech_input: none)")
