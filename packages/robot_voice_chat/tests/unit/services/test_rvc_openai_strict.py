"""OpenAICompatLLM and OpenAITranscriptionInput through the real ``openai`` SDK against the
strict local fake (robot_stack_testing.fake_openai): requests must pass the real API's checks."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest

from robot_stack_testing.fake_api_server import serve_in_thread
from robot_stack_testing.fake_openai import FakeOpenAIApi
from robot_voice_chat.services.llm.base import LLMError, Message, ToolDefinition, ToolResult
from robot_voice_chat.services.llm.openai_compat import OpenAICompatLLM
from robot_voice_chat.services.speech.base import TranscriptionError
from robot_voice_chat.services.speech.openai_transcription import OpenAITranscriptionInput

TOOLS = [ToolDefinition(name="navigation.navigate_to", description="drive")]


def drive(body: dict[str, Any]) -> dict[str, Any]:
    if body["messages"][-1]["role"] == "tool":
        return {"content": "Arrived."}
    return {"content": None, "tool_calls": [{"name": "navigation__navigate_to", "arguments": {}}]}


@pytest.fixture
def api() -> Iterator[tuple[FakeOpenAIApi, str]]:
    fake = FakeOpenAIApi(drive, transcriber=lambda audio, name: f"{len(audio)} bytes in {name}")
    with serve_in_thread(fake.app()) as url:
        yield fake, f"{url}/v1"


async def test_a_tool_round_trip_passes_the_strict_checks_and_is_priced(
    api: tuple[FakeOpenAIApi, str],
) -> None:
    fake, url = api
    prices = {"input": 0.59, "output": 0.79}
    llm = OpenAICompatLLM(base_url=url, api_key="k", model="m", max_retries=0, prices=prices)
    history = [Message(role="system", content="s"), Message(role="user", content="go")]
    first = await llm.chat(history, TOOLS)
    [call] = first.tool_calls
    assert call.name == "navigation.navigate_to"
    assert first.usage.cost_usd is not None
    assert first.usage.cost_usd > 0
    answered = Message(role="user", tool_results=[ToolResult(tool_call_id=call.id, content="ok")])
    second = await llm.chat([*history, first.as_message(), answered], TOOLS)
    assert second.text == "Arrived."
    streamed = [e async for e in llm.chat_stream([*history, first.as_message(), answered], TOOLS)]
    assert "".join(e.delta for e in streamed[:-1]) == "Arrived."
    assert not fake.rejections
    assert fake.requests[0]["tools"][0]["function"]["name"] == "navigation__navigate_to"
    await llm.aclose()


async def test_an_unanswered_tool_call_is_rejected_as_the_real_api_would(
    api: tuple[FakeOpenAIApi, str],
) -> None:
    fake, url = api
    llm = OpenAICompatLLM(base_url=url, api_key="k", model="m", max_retries=0)
    history = [Message(role="user", content="go")]
    first = await llm.chat(history, TOOLS)
    with pytest.raises(LLMError, match="did not have response messages"):
        await llm.chat([*history, first.as_message(), Message(role="user", content="?")], TOOLS)
    assert fake.rejections
    await llm.aclose()


async def test_transcription_sends_the_multipart_shape_the_api_expects(
    api: tuple[FakeOpenAIApi, str],
) -> None:
    fake, url = api
    speech = OpenAITranscriptionInput(base_url=url, api_key="k")
    text = await speech.transcribe(b"\x1a\x45\xdf\xa3audio", "audio/webm;codecs=opus")
    assert text == "9 bytes in utterance.webm"
    assert fake.transcriptions == [{"model": "whisper-1", "file": "utterance.webm"}]
    with pytest.raises(TranscriptionError):
        await speech.transcribe(b"", "audio/webm")
    await speech.aclose()
