"""OpenAI-compatible adapter, transcription and espeak speech against local fakes."""

from __future__ import annotations

import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from robot_stack_testing import async_wait_until
from robot_stack_testing.fake_api_server import serve_in_thread
from robot_stack_testing.fake_openai import FakeOpenAIApi
from robot_voice_chat.services.llm.base import Message, ToolCall, ToolDefinition, ToolResult
from robot_voice_chat.services.llm.openai_compat import OpenAICompatLLM
from robot_voice_chat.services.speech.espeak import EspeakSpeechOutput
from robot_voice_chat.services.speech.openai_transcription import OpenAITranscriptionInput


def respond(body: dict[str, Any]) -> dict[str, Any]:
    """Scripted like the old fake, but behind the strict API that rejects bad requests."""
    if body.get("stream"):
        call = {"name": "start_mission", "arguments": {"instruction": "go", "ack": "ok"}}
        return {"content": "Hi there.", "tool_calls": [call]}
    return {
        "content": "Going.",
        "tool_calls": [{"name": "navigation__navigate_to", "arguments": {"location": "lab"}}],
    }


@pytest.fixture
def fake_openai() -> Iterator[tuple[FakeOpenAIApi, str]]:
    fake = FakeOpenAIApi(respond, transcriber=lambda audio, name: "  drive to the lab \n")
    with serve_in_thread(fake.app()) as url:
        yield fake, f"{url}/v1"


async def test_openai_compat_translates_dotted_tools_and_results(
    fake_openai: tuple[FakeOpenAIApi, str],
) -> None:
    fake, url = fake_openai
    llm = OpenAICompatLLM(base_url=url, api_key="test", model="m", max_retries=0)
    history = [
        Message(role="system", content="sys"),
        Message(role="user", content="go"),
        Message(
            role="assistant",
            tool_calls=[ToolCall(id="c0", name="navigation.get_pose", arguments={})],
        ),
        Message(role="user", tool_results=[ToolResult(tool_call_id="c0", content="{}")]),
    ]
    tools = [ToolDefinition(name="navigation.navigate_to", description="drive")]
    response = await llm.chat(history, tools)
    await llm.aclose()
    assert not fake.rejections
    sent = fake.requests[0]
    assert sent["tools"][0]["function"]["name"] == "navigation__navigate_to"
    assert sent["messages"][2]["tool_calls"][0]["function"]["name"] == "navigation__get_pose"
    assert sent["messages"][3] == {"role": "tool", "tool_call_id": "c0", "content": "{}"}
    [call] = response.tool_calls
    assert (call.name, call.arguments) == ("navigation.navigate_to", {"location": "lab"})
    assert response.usage.input_tokens > 0


async def test_openai_compat_streams_text_and_assembles_tool_calls(
    fake_openai: tuple[FakeOpenAIApi, str],
) -> None:
    _, url = fake_openai
    llm = OpenAICompatLLM(base_url=url, api_key="test", model="m", max_retries=0)
    events = [e async for e in llm.chat_stream([Message(role="user", content="hi")])]
    await llm.aclose()
    assert "".join(e.delta for e in events) == "Hi there."
    final = events[-1].response
    assert final is not None
    [call] = final.tool_calls
    assert (call.name, call.arguments) == ("start_mission", {"instruction": "go", "ack": "ok"})


async def test_transcription_returns_the_trimmed_text(
    fake_openai: tuple[FakeOpenAIApi, str],
) -> None:
    fake, url = fake_openai
    stt = OpenAITranscriptionInput(base_url=url, api_key="test")
    assert await stt.transcribe(b"RIFF....", "audio/wav") == "drive to the lab"
    assert fake.transcriptions == [{"model": "whisper-1", "file": "utterance.wav"}]
    await stt.aclose()


def test_empty_keys_are_refused_for_selected_adapters() -> None:
    with pytest.raises(ValueError, match="empty"):
        OpenAICompatLLM(base_url="http://127.0.0.1:1/v1", api_key="", model="m")
    with pytest.raises(ValueError, match="empty"):
        OpenAITranscriptionInput(base_url="http://127.0.0.1:1/v1", api_key="")


async def test_espeak_speaks_sentences_in_order_and_interrupt_drops_the_queue(
    tmp_path: Path,
) -> None:
    log, started = tmp_path / "spoken.txt", tmp_path / "started.txt"
    engine = tmp_path / "engine.py"
    engine.write_text(
        "import sys, time, pathlib\n"
        "text = sys.argv[-1]\n"
        f"pathlib.Path({str(started)!r}).open('a').write(text + '\\n')\n"
        "time.sleep(2 if text.startswith('slow') else 0)\n"
        f"pathlib.Path({str(log)!r}).open('a').write(text + '\\n')\n"
    )
    speech = EspeakSpeechOutput([sys.executable, str(engine)])
    await speech.say("Hello there. I am a robot.")
    await speech.drain(10)
    assert log.read_text().splitlines() == ["Hello there.", "I am a robot."]

    await speech.say("slow sentence. never spoken.")
    await async_wait_until(
        lambda: "slow sentence." in started.read_text().splitlines(), 10, "the slow sentence"
    )
    await speech.interrupt()
    await speech.drain(10)
    assert log.read_text().splitlines() == ["Hello there.", "I am a robot."]
    await speech.aclose()


def test_a_missing_tts_engine_is_a_clear_error() -> None:
    with pytest.raises(ValueError, match="apt install espeak-ng"):
        EspeakSpeechOutput(["no-such-tts-engine"])
