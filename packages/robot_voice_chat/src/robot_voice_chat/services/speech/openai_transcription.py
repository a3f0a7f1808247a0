"""SpeechInput over an OpenAI-compatible ``audio/transcriptions`` endpoint."""

from __future__ import annotations

import openai
from pydantic import SecretStr

from robot_voice_chat.services.speech.base import Outage, SpeechInput, TranscriptionError

_EXT = {
    "audio/webm": "webm",
    "audio/wav": "wav",
    "audio/x-wav": "wav",
    "audio/mpeg": "mp3",
    "audio/ogg": "ogg",
}


def outage_of(exc: openai.OpenAIError) -> Outage | None:
    """The named outages another engine answers for; None: the request itself was refused."""
    if isinstance(exc, openai.APITimeoutError):
        return "timeout"
    if isinstance(exc, openai.APIConnectionError):
        return "network"
    if isinstance(exc, openai.RateLimitError):
        return "rate_limit"
    if isinstance(exc, openai.AuthenticationError | openai.PermissionDeniedError):
        return "auth"
    if isinstance(exc, openai.InternalServerError):
        return "server"
    if isinstance(exc, openai.APIStatusError) and exc.status_code >= 500:
        return "server"
    return None


class OpenAITranscriptionInput(SpeechInput):
    def __init__(
        self,
        base_url: str,
        api_key: str | SecretStr,
        model: str = "whisper-1",
        request_timeout_s: float = 30.0,
        required: bool = True,
    ) -> None:
        """``required: false`` (a chain's cloud member): no key → not configured, and the
        chain uses the next engine, instead of refusing to start."""
        key = api_key if isinstance(api_key, SecretStr) else SecretStr(api_key or "")
        self.model = model
        self.name = f"cloud transcription ({model})"
        if not key.get_secret_value():
            if required:
                raise ValueError("OPENAI_API_KEY is empty but the openai speech_input is selected")
            self.configured = False
            key = SecretStr("unset")
        self._client = openai.AsyncOpenAI(
            base_url=base_url,
            api_key=key.get_secret_value(),
            timeout=request_timeout_s,
            max_retries=1,
        )

    async def transcribe(self, audio: bytes, mime_type: str) -> str:
        name = f"utterance.{_EXT.get(mime_type.split(';')[0], 'webm')}"
        try:
            result = await self._client.audio.transcriptions.create(
                model=self.model, file=(name, audio, mime_type)
            )
        except openai.OpenAIError as exc:
            raise TranscriptionError(f"transcription failed: {exc}", outage_of(exc)) from exc
        return result.text.strip()

    async def aclose(self) -> None:
        await self._client.close()
