"""AnthropicLLM through the real ``anthropic`` SDK against a local fake Messages API (§7)."""

from __future__ import annotations

import asyncio
import json
from collections.abc import AsyncIterator
from dataclasses import dataclass, field
from typing import Any

import pytest
import uvicorn
from starlette.applications import Starlette
from starlette.requests import Request
from starlette.responses import JSONResponse, Response, StreamingResponse
from starlette.routing import Route

from robot_stack_testing import async_wait_until
from robot_voice_chat.services.llm.anthropic import AnthropicLLM
from robot_voice_chat.services.llm.base import (
    LLMError,
    Message,
    ToolCall,
    ToolDefinition,
    ToolResult,
)


@dataclass
class FakeMessagesApi:
    """Scripted answers: dicts are JSON messages, ints are error statuses, 'sse' streams,
    'hang' never answers (timeouts)."""

    script: list[Any] = field(default_factory=list)
    requests: list[dict[str, Any]] = field(default_factory=list)

    async def messages(self, request: Request) -> Response:
        self.requests.append(json.loads(await request.body()))
        item = self.script.pop(0)
        if item == "hang":
            await asyncio.sleep(1.5)
        if isinstance(item, int):
            return JSONResponse(
                {"type": "error", "error": {"type": "overloaded_error", "message": "busy"}},
                status_code=item,
            )
        if item == "sse":
            return StreamingResponse(_sse(), media_type="text/event-stream")
        return JSONResponse(item)


def message(content: list[dict[str, Any]], stop: str = "end_turn") -> dict[str, Any]:
    return {
        "id": "msg_1",
        "type": "message",
        "role": "assistant",
        "model": "claude-opus-4-8",
        "content": content,
        "stop_reason": stop,
        "stop_sequence": None,
        "usage": {"input_tokens": 10, "output_tokens": 5, "cache_read_input_tokens": 7},
    }


def _delta(text: str) -> dict[str, Any]:
    delta = {"type": "text_delta", "text": text}
    return {"type": "content_block_delta", "index": 0, "delta": delta}


async def _sse() -> AsyncIterator[bytes]:
    start = message([])
    start["usage"] = {"input_tokens": 3, "output_tokens": 0}
    block = {"type": "text", "text": ""}
    end = {"stop_reason": "end_turn", "stop_sequence": None}
    events = [
        {"type": "message_start", "message": start},
        {"type": "content_block_start", "index": 0, "content_block": block},
        _delta("Hello "),
        _delta("there."),
        {"type": "content_block_stop", "index": 0},
        {"type": "message_delta", "delta": end, "usage": {"output_tokens": 2}},
        {"type": "message_stop"},
    ]
    for data in events:
        kind: Any = data["type"]  # type: ignore[index]
        yield f"event: {kind}\ndata: {json.dumps(data)}\n\n".encode()


@pytest.fixture
async def api(tcp_port: int) -> AsyncIterator[tuple[FakeMessagesApi, str]]:
    fake = FakeMessagesApi()
    app = Starlette(routes=[Route("/v1/messages", fake.messages, methods=["POST"])])
    server = uvicorn.Server(
        uvicorn.Config(app, host="127.0.0.1", port=tcp_port, log_level="warning", lifespan="off")
    )
    task = asyncio.create_task(server.serve())
    await async_wait_until(lambda: server.started, 10, "fake API serving")
    yield fake, f"http://127.0.0.1:{tcp_port}"
    server.should_exit = True
    await asyncio.wait_for(task, 10)


@pytest.fixture
async def clients() -> AsyncIterator[list[AnthropicLLM]]:
    made: list[AnthropicLLM] = []
    yield made
    for client in made:
        await client.aclose()


def llm(url: str, made: list[AnthropicLLM], **kw: Any) -> AnthropicLLM:
    client = AnthropicLLM(api_key="test", base_url=url, max_retries=kw.pop("max_retries", 0), **kw)
    made.append(client)
    return client


CONVERSATION = [
    Message(role="system", content="You are the mission planner."),
    Message(role="user", content="drive to the mailroom"),
    Message(
        role="assistant",
        content="",
        tool_calls=[
            ToolCall(id="tu_1", name="navigation.navigate_to", arguments={"location": "mailroom"})
        ],
    ),
    Message(
        role="user", tool_results=[ToolResult(tool_call_id="tu_1", content='{"task_id":"nav-1"}')]
    ),
    Message(role="user", content="[task nav-1] done"),
]
TOOLS = [
    ToolDefinition(
        name="set_plan", description="plan", parameters={"type": "object", "properties": {}}
    )
]


async def test_request_shape_and_tool_translation_both_ways(
    api: tuple[FakeMessagesApi, str], clients: list[AnthropicLLM]
) -> None:
    fake, url = api
    fake.script.append(
        message(
            [
                {"type": "thinking", "thinking": "plan first", "signature": "sig"},
                {"type": "text", "text": "Planning."},
                {"type": "tool_use", "id": "tu_2", "name": "set_plan", "input": {"steps": []}},
            ],
            stop="tool_use",
        )
    )
    response = await llm(url, clients).chat(CONVERSATION, TOOLS)

    sent = fake.requests[0]
    assert sent["model"] == "claude-opus-4-8"
    assert sent["max_tokens"] == 16000
    assert sent["thinking"] == {"type": "adaptive"}
    assert sent["output_config"] == {"effort": "high"}
    assert not {"temperature", "top_p", "top_k"} & set(sent)
    assert sent["system"] == [
        {
            "type": "text",
            "text": "You are the mission planner.",
            "cache_control": {"type": "ephemeral"},
        }
    ]
    assert sent["tools"] == [
        {
            "name": "set_plan",
            "description": "plan",
            "input_schema": {"type": "object", "properties": {}},
        }
    ]
    assert [m["role"] for m in sent["messages"]] == ["user", "assistant", "user"]
    assert sent["messages"][1]["content"] == [
        {
            "type": "tool_use",
            "id": "tu_1",
            "name": "navigation__navigate_to",
            "input": {"location": "mailroom"},
        }
    ]
    assert sent["messages"][2]["content"][0] == {
        "type": "tool_result",
        "tool_use_id": "tu_1",
        "content": '{"task_id":"nav-1"}',
        "is_error": False,
    }
    assert sent["messages"][2]["content"][1] == {"type": "text", "text": "[task nav-1] done"}

    assert response.has_tool_calls
    assert response.tool_calls == [ToolCall(id="tu_2", name="set_plan", arguments={"steps": []})]
    assert response.text == "Planning."
    assert response.usage.cache_read_tokens == 7
    # the thinking block goes back verbatim on the next step
    fake.script.append(message([{"type": "text", "text": "ok"}]))
    await llm(url, clients).chat([*CONVERSATION, response.as_message()], TOOLS)
    assert fake.requests[1]["messages"][-1]["content"][0] == {
        "type": "thinking",
        "thinking": "plan first",
        "signature": "sig",
    }


async def test_streaming_yields_text_deltas_then_the_final_response(
    api: tuple[FakeMessagesApi, str], clients: list[AnthropicLLM]
) -> None:
    fake, url = api
    fake.script.append("sse")
    events = [e async for e in llm(url, clients).chat_stream(CONVERSATION[:2])]
    assert [e.delta for e in events[:-1]] == ["Hello ", "there."]
    final = events[-1].response
    assert final is not None
    assert final.text == "Hello there."
    assert fake.requests[0]["stream"] is True


async def test_overloaded_and_server_errors_are_retried(
    api: tuple[FakeMessagesApi, str], clients: list[AnthropicLLM]
) -> None:
    fake, url = api
    fake.script += [529, 500, message([{"type": "text", "text": "finally"}])]
    response = await llm(url, clients, max_retries=2).chat(CONVERSATION[:2])
    assert response.text == "finally"
    assert len(fake.requests) == 3


async def test_exhausted_retries_and_timeouts_become_llm_errors(
    api: tuple[FakeMessagesApi, str], clients: list[AnthropicLLM]
) -> None:
    fake, url = api
    fake.script += [529]
    with pytest.raises(LLMError, match="anthropic"):
        await llm(url, clients).chat(CONVERSATION[:2])
    fake.script += ["hang"]
    with pytest.raises(LLMError, match="Timeout"):
        await llm(url, clients, request_timeout_s=0.3).chat(CONVERSATION[:2])


def test_an_empty_key_is_refused_when_the_adapter_is_selected() -> None:
    with pytest.raises(ValueError, match="ANTHROPIC_API_KEY is empty"):
        AnthropicLLM(api_key="")
