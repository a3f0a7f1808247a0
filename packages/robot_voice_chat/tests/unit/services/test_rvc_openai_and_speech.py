"""OpenAI-compatible adapter, transcription and espeak speech against local fakes."""

from __future__ import annotations

import asyncio
import json
import sys
from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

import pytest
import uvicorn
from starlette.applications import Starlette
from starlette.requests import Request
from starlette.responses import JSONResponse, Response, StreamingResponse
from starlette.routing import Route

from robot_stack_testing import async_wait_until
from robot_voice_chat.services.llm.base import Message, ToolCall, ToolDefinition, ToolResult
from robot_voice_chat.services.llm.openai_compat import OpenAICompatLLM
from robot_voice_chat.services.speech.espeak import EspeakSpeechOutput
from robot_voice_chat.services.speech.openai_transcription import OpenAITranscriptionInput


class FakeOpenAI:
    def __init__(self) -> None:
        self.requests: list[Any] = []

    async def chat(self, request: Request) -> Response:
        body = json.loads(await request.body())
        self.requests.append(body)
        if body.get("stream"):
            return StreamingResponse(self._stream(), media_type="text/event-stream")
        call = {
            "id": "c1",
            "type": "function",
            "function": {"name": "navigation__navigate_to", "arguments": '{"location": "lab"}'},
        }
        msg = {"role": "assistant", "content": "Going.", "tool_calls": [call]}
        return JSONResponse(
            {
                "id": "x",
                "object": "chat.completion",
                "created": 0,
                "model": body["model"],
                "choices": [{"index": 0, "message": msg, "finish_reason": "tool_calls"}],
                "usage": {"prompt_tokens": 5, "completion_tokens": 2, "total_tokens": 7},
            }
        )

    async def _stream(self) -> AsyncIterator[bytes]:
        deltas = [
            {"content": "Hi "},
            {"content": "there."},
            {
                "tool_calls": [
                    {
                        "index": 0,
                        "id": "c2",
                        "type": "function",
                        "function": {"name": "start_mission", "arguments": '{"instruction":'},
                    }
                ]
            },
            {"tool_calls": [{"index": 0, "function": {"arguments": ' "go", "ack": "ok"}'}}]},
        ]
        for delta in deltas:
            chunk = {
                "id": "x",
                "object": "chat.completion.chunk",
                "created": 0,
                "model": "m",
                "choices": [{"index": 0, "delta": delta, "finish_reason": None}],
            }
            yield f"data: {json.dumps(chunk)}\n\n".encode()
        yield b"data: [DONE]\n\n"

    async def transcribe(self, request: Request) -> Response:
        async with request.form() as form:
            self.requests.append({"model": form["model"]})
        return JSONResponse({"text": " drive to the lab "})


@pytest.fixture
async def fake_openai(tcp_port: int) -> AsyncIterator[tuple[FakeOpenAI, str]]:
    fake = FakeOpenAI()
    app = Starlette(
        routes=[
            Route("/v1/chat/completions", fake.chat, methods=["POST"]),
            Route("/v1/audio/transcriptions", fake.transcribe, methods=["POST"]),
        ]
    )
    server = uvicorn.Server(
        uvicorn.Config(app, host="127.0.0.1", port=tcp_port, log_level="warning", lifespan="off")
    )
    task = asyncio.create_task(server.serve())
    await async_wait_until(lambda: server.started, 10, "fake API serving")
    yield fake, f"http://127.0.0.1:{tcp_port}/v1"
    server.should_exit = True
    await asyncio.wait_for(task, 10)


async def test_openai_compat_translates_dotted_tools_and_results(
    fake_openai: tuple[FakeOpenAI, str],
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
    sent = fake.requests[0]
    assert sent["tools"][0]["function"]["name"] == "navigation__navigate_to"
    assert sent["messages"][2]["tool_calls"][0]["function"]["name"] == "navigation__get_pose"
    assert sent["messages"][3] == {"role": "tool", "tool_call_id": "c0", "content": "{}"}
    assert response.tool_calls == [
        ToolCall(id="c1", name="navigation.navigate_to", arguments={"location": "lab"})
    ]
    assert response.usage.input_tokens == 5


async def test_openai_compat_streams_text_and_assembles_tool_calls(
    fake_openai: tuple[FakeOpenAI, str],
) -> None:
    _, url = fake_openai
    llm = OpenAICompatLLM(base_url=url, api_key="test", model="m", max_retries=0)
    events = [e async for e in llm.chat_stream([Message(role="user", content="hi")])]
    await llm.aclose()
    assert "".join(e.delta for e in events) == "Hi there."
    final = events[-1].response
    assert final is not None
    assert final.tool_calls == [
        ToolCall(id="c2", name="start_mission", arguments={"instruction": "go", "ack": "ok"})
    ]


async def test_transcription_returns_the_trimmed_text(fake_openai: tuple[FakeOpenAI, str]) -> None:
    fake, url = fake_openai
    stt = OpenAITranscriptionInput(base_url=url, api_key="test")
    assert await stt.transcribe(b"RIFF....", "audio/wav") == "drive to the lab"
    assert fake.requests[-1] == {"model": "whisper-1"}
    await stt._client.close()


def test_empty_keys_are_refused_for_selected_adapters() -> None:
    with pytest.raises(ValueError, match="empty"):
        OpenAICompatLLM(base_url="http://127.0.0.1:1/v1", api_key="", model="m")
    with pytest.raises(ValueError, match="empty"):
        OpenAITranscriptionInput(base_url="http://127.0.0.1:1/v1", api_key="")


async def test_espeak_speaks_sentences_in_order_and_interrupt_drops_the_queue(
    tmp_path: Path,
) -> None:
    log = tmp_path / "spoken.txt"
    engine = tmp_path / "engine.py"
    engine.write_text(
        "import sys, time, pathlib\n"
        "text = sys.argv[-1]\n"
        "time.sleep(2 if text.startswith('slow') else 0)\n"
        f"pathlib.Path({str(log)!r}).open('a').write(text + '\\n')\n"
    )
    speech = EspeakSpeechOutput([sys.executable, str(engine)])
    await speech.say("Hello there. I am a robot.")
    await speech.drain(10)
    assert log.read_text().splitlines() == ["Hello there.", "I am a robot."]

    await speech.say("slow sentence. never spoken.")
    await asyncio.sleep(0.3)
    await speech.interrupt()
    await speech.drain(10)
    assert log.read_text().splitlines() == ["Hello there.", "I am a robot."]
    await speech.aclose()


def test_a_missing_tts_engine_is_a_clear_error() -> None:
    with pytest.raises(ValueError, match="apt install espeak-ng"):
        EspeakSpeechOutput(["no-such-tts-engine"])
