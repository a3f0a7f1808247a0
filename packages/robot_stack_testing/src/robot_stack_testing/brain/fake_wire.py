"""Model stand-ins behind the strict fake APIs (tests, benchmarks): a provider of this app
(e.g. the rules planner) answers the wire requests the fake Anthropic / OpenAI servers
validated, so a whole mission can run through the real SDK adapters without a model."""

from __future__ import annotations

import json
from collections.abc import Callable, Coroutine
from typing import Any, TypeVar

from robot_voice_chat.services.llm.base import (
    LLMProvider,
    LLMResponse,
    Message,
    ToolCall,
    ToolDefinition,
    ToolResult,
)
from robot_voice_chat.services.llm.tool_names import encode

T = TypeVar("T")


def run_sync(coro: Coroutine[Any, Any, T]) -> T:
    """Run a coroutine that never suspends (the rules providers) from synchronous code."""
    try:
        coro.send(None)
    except StopIteration as done:
        return done.value  # type: ignore[no-any-return]
    coro.close()
    raise RuntimeError("this stand-in model must not await anything")


def app_name(wire: str) -> str:
    return wire.replace("__", ".", 1)


def _text(content: Any) -> str:
    if isinstance(content, str):
        return content
    if isinstance(content, list):
        return "\n".join(b.get("text", "") for b in content if isinstance(b, dict))
    return ""


def from_anthropic_request(body: dict[str, Any]) -> tuple[list[Message], list[ToolDefinition]]:
    messages = [Message(role="system", content=_text(body.get("system")))]
    for m in body["messages"]:
        blocks = (
            m["content"]
            if isinstance(m["content"], list)
            else [{"type": "text", "text": m["content"]}]
        )
        texts = [b["text"] for b in blocks if b.get("type") == "text"]
        if m["role"] == "assistant":
            calls = [
                ToolCall(id=b["id"], name=app_name(b["name"]), arguments=b.get("input") or {})
                for b in blocks
                if b.get("type") == "tool_use"
            ]
            messages.append(Message(role="assistant", content="".join(texts), tool_calls=calls))
            continue
        results = [
            ToolResult(
                tool_call_id=b["tool_use_id"],
                content=_text(b.get("content")),
                is_error=bool(b.get("is_error")),
            )
            for b in blocks
            if b.get("type") == "tool_result"
        ]
        messages.append(Message(role="user", content="\n".join(texts), tool_results=results))
    tools = [
        ToolDefinition(name=app_name(t["name"]), description=t.get("description", ""))
        for t in body.get("tools") or []
    ]
    return messages, tools


def anthropic_responder(model: LLMProvider) -> Callable[[dict[str, Any]], list[dict[str, Any]]]:
    def respond(body: dict[str, Any]) -> list[dict[str, Any]]:
        messages, tools = from_anthropic_request(body)
        response: LLMResponse = run_sync(model.chat(messages, tools))
        blocks: list[dict[str, Any]] = []
        if response.text.strip():
            blocks.append({"type": "text", "text": response.text})
        blocks += [
            {"type": "tool_use", "name": encode(c.name), "input": c.arguments}
            for c in response.tool_calls
        ]
        return blocks

    return respond


def from_openai_request(body: dict[str, Any]) -> tuple[list[Message], list[ToolDefinition]]:
    messages: list[Message] = []
    for m in body["messages"]:
        role = m["role"]
        if role == "tool":
            result = ToolResult(tool_call_id=m["tool_call_id"], content=_text(m.get("content")))
            if messages and messages[-1].role == "user" and messages[-1].tool_results:
                messages[-1].tool_results.append(result)
            else:
                messages.append(Message(role="user", tool_results=[result]))
            continue
        calls = [
            ToolCall(
                id=c["id"],
                name=app_name(c["function"]["name"]),
                arguments=json.loads(c["function"].get("arguments") or "{}"),
            )
            for c in m.get("tool_calls") or []
        ]
        messages.append(
            Message(
                role=role if role != "developer" else "system",
                content=_text(m.get("content")),
                tool_calls=calls,
            )
        )
    tools = [ToolDefinition(name=app_name(t["function"]["name"])) for t in body.get("tools") or []]
    return messages, tools


def openai_responder(model: LLMProvider) -> Callable[[dict[str, Any]], dict[str, Any]]:
    def respond(body: dict[str, Any]) -> dict[str, Any]:
        messages, tools = from_openai_request(body)
        response: LLMResponse = run_sync(model.chat(messages, tools))
        return {
            "content": response.text or None,
            "tool_calls": [
                {"name": encode(c.name), "arguments": c.arguments} for c in response.tool_calls
            ],
        }

    return respond
