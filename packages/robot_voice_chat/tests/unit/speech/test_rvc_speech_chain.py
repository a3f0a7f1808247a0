"""The speech chain (issue 36): the cloud transcriber is used while it answers; each named
outage (network, timeout, 5xx, 429, auth) is answered by the on-board recognizer, said once per
outage; the cloud is used again as soon as it answers. The cloud is the real OpenAI client
against a fake API that fails as the real one does."""

from __future__ import annotations

from collections.abc import Callable

import httpx
import numpy as np
import openai
import pytest

from robot_voice_chat.services.speech.audio import Utterance
from robot_voice_chat.services.speech.base import Heard, SpeechInput, TranscriptionError
from robot_voice_chat.services.speech.chain import SpeechChain
from robot_voice_chat.services.speech.openai_transcription import OpenAITranscriptionInput

UTTERANCE = Utterance.from_pcm(np.zeros(1600, np.int16))
Handler = Callable[[httpx.Request], httpx.Response]


class OnBoard(SpeechInput):
    name = "on-board recognizer"

    def __init__(self) -> None:
        self.calls = 0

    async def transcribe(self, audio: bytes, mime_type: str) -> str:
        raise AssertionError("hear() is used")

    async def hear(self, utterance: Utterance) -> Heard:
        self.calls += 1
        return Heard("go to the kitchen", 0.8, self.name, "motion")


def cloud(handler: Handler) -> OpenAITranscriptionInput:
    engine = OpenAITranscriptionInput("https://api.openai.test/v1", "sk-test", required=True)
    engine._client = openai.AsyncOpenAI(
        base_url="https://api.openai.test/v1",
        api_key="sk-test",
        max_retries=0,
        http_client=httpx.AsyncClient(transport=httpx.MockTransport(handler)),
    )
    return engine


def status(code: int) -> Handler:
    return lambda request: httpx.Response(code, json={"error": {"message": f"HTTP {code}"}})


def raises(exc: type[Exception]) -> Handler:
    def handler(request: httpx.Request) -> httpx.Response:
        raise exc("simulated", request=request)  # type: ignore[call-arg]

    return handler


OUTAGES = {
    "server": status(503),
    "rate_limit": status(429),
    "auth": status(401),
    "network": raises(httpx.ConnectError),
    "timeout": raises(httpx.ReadTimeout),
}


@pytest.mark.parametrize("outage", sorted(OUTAGES))
async def test_each_outage_is_answered_on_board_said_once_and_the_cloud_is_back(
    outage: str,
) -> None:
    failing = {"now": True}

    def handler(request: httpx.Request) -> httpx.Response:
        if failing["now"]:
            return OUTAGES[outage](request)
        return httpx.Response(200, json={"text": "find the scissors"})

    onboard = OnBoard()
    chain = SpeechChain([cloud(handler), onboard])
    first = await chain.hear(UTTERANCE)
    assert first.text == "go to the kitchen"
    assert first.engine == "on-board recognizer"
    assert first.notice is not None
    assert "on-board recognizer instead" in first.notice
    assert chain.outage is not None
    assert chain.outage[1] == outage
    second = await chain.hear(UTTERANCE)
    assert second.notice is None  # said once per outage
    assert onboard.calls == 2
    failing["now"] = False
    back = await chain.hear(UTTERANCE)
    assert back.text == "find the scissors"
    assert back.engine == "cloud transcription (whisper-1)"
    assert chain.outage is None
    assert onboard.calls == 2


async def test_a_refused_recording_is_not_an_outage() -> None:
    chain = SpeechChain([cloud(status(400)), OnBoard()])
    with pytest.raises(TranscriptionError) as caught:
        await chain.hear(UTTERANCE)
    assert caught.value.outage is None


def test_without_a_key_the_chain_is_the_on_board_recognizer_alone() -> None:
    unkeyed = OpenAITranscriptionInput("https://api.openai.test/v1", "", required=False)
    assert not unkeyed.configured
    chain = SpeechChain([unkeyed, OnBoard()])
    assert chain.name == "on-board recognizer"
    assert [p.name for p in chain.providers] == ["on-board recognizer"]
    with pytest.raises(ValueError, match="OPENAI_API_KEY"):
        OpenAITranscriptionInput("https://api.openai.test/v1", "")
