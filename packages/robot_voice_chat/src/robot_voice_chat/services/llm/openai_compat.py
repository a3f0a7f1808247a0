"""OpenAICompatLLM: any OpenAI-compatible chat endpoint (OpenAI, Groq, Ollama, vLLM) by base_url.

Function names may not contain dots: ``server.tool`` travels as ``server__tool``
(:mod:`robot_voice_chat.services.llm.tool_names`, shared with the Anthropic adapter).
"""

from __future__ import annotations

import json
from collections.abc import AsyncIterator
from typing import Any

import openai
from pydantic import SecretStr

from robot_voice_chat.services.llm.base import (
    LLMError,
    LLMProvider,
    LLMResponse,
    Message,
    StreamEvent,
    ToolCall,
    ToolDefinition,
    Usage,
)
from robot_voice_chat.services.llm.pricing import Prices, priced
from robot_voice_chat.services.llm.tool_names import ToolNames


def openai_usage(usage: Any) -> Usage:
    """prompt_tokens include the cached ones (prompt_tokens_details.cached_tokens)."""
    if usage is None:
        return Usage()
    details = getattr(usage, "prompt_tokens_details", None)
    cached = (getattr(details, "cached_tokens", None) or 0) if details is not None else 0
    return Usage(
        input_tokens=(usage.prompt_tokens or 0) - cached,
        output_tokens=usage.completion_tokens or 0,
        cache_read_tokens=cached,
    )


def tool_names(tools: list[ToolDefinition] | None) -> ToolNames:
    """The request's name map; a collision is a clear :class:`LLMError` before any call."""
    try:
        return ToolNames(t.name for t in tools or [])
    except ValueError as exc:
        raise LLMError(f"tool names: {exc}") from exc


def to_openai_messages(
    messages: list[Message], names: ToolNames | None = None, empty_content: str | None = None
) -> list[dict[str, Any]]:
    """``empty_content``: what a tool-calls-only assistant turn carries as content (OpenAI
    takes null; Ollama rejects null, so local servers get "")."""
    names = names or ToolNames()
    out: list[dict[str, Any]] = []
    for m in messages:
        if m.role == "assistant":
            item: dict[str, Any] = {"role": "assistant", "content": m.content or empty_content}
            if m.tool_calls:
                item["tool_calls"] = [
                    {
                        "id": c.id,
                        "type": "function",
                        "function": {
                            "name": names.wire(c.name),
                            "arguments": json.dumps(c.arguments),
                        },
                    }
                    for c in m.tool_calls
                ]
            out.append(item)
            continue
        out += [
            {"role": "tool", "tool_call_id": r.tool_call_id, "content": r.content}
            for r in m.tool_results
        ]
        if m.content:
            out.append({"role": m.role, "content": m.content})
    return out


def _arguments(raw: str | None) -> dict[str, Any]:
    try:
        value = json.loads(raw or "{}")
    except ValueError:
        return {"_raw": raw}
    return value if isinstance(value, dict) else {"_value": value}


class OpenAICompatLLM(LLMProvider):
    name = "openai_compat"

    def __init__(
        self,
        base_url: str,
        api_key: str | SecretStr,
        model: str,
        max_tokens: int = 1024,
        request_timeout_s: float = 30.0,
        max_retries: int = 2,
        require_key: bool = True,
        prices: dict[str, float] | None = None,
        empty_content: str | None = None,
    ) -> None:
        self.prices = Prices.parse(prices)
        self.empty_content = empty_content
        key = api_key if isinstance(api_key, SecretStr) else SecretStr(api_key or "")
        if require_key and not key.get_secret_value():
            raise ValueError(f"the API key for {base_url} is empty but this adapter is selected")
        self.model = model
        self.max_tokens = max_tokens
        self._client = openai.AsyncOpenAI(
            base_url=base_url,
            api_key=key.get_secret_value() or "unused",
            timeout=request_timeout_s,
            max_retries=max_retries,
        )

    @property
    def understanding_label(self) -> str:
        return f"{self.name} ({self.model})"

    def request(
        self,
        messages: list[Message],
        tools: list[ToolDefinition] | None,
        names: ToolNames | None = None,
    ) -> dict[str, Any]:
        names = names if names is not None else tool_names(tools)
        params: dict[str, Any] = {
            "model": self.model,
            "max_tokens": self.max_tokens,
            "messages": to_openai_messages(messages, names, self.empty_content),
        }
        if tools:
            params["tools"] = [
                {
                    "type": "function",
                    "function": {
                        "name": names.wire(t.name),
                        "description": t.description,
                        "parameters": t.parameters,
                    },
                }
                for t in tools
            ]
        return params

    async def chat(
        self, messages: list[Message], tools: list[ToolDefinition] | None = None
    ) -> LLMResponse:
        names = tool_names(tools)
        try:
            completion = await self._client.chat.completions.create(
                **self.request(messages, tools, names)
            )
        except openai.OpenAIError as exc:
            raise LLMError(f"{self.model}: {type(exc).__name__}: {exc}") from exc
        choice = completion.choices[0]
        calls = [
            ToolCall(
                id=c.id,
                name=names.app(c.function.name),
                arguments=_arguments(c.function.arguments),
            )
            for c in choice.message.tool_calls or []
            if c.type == "function"
        ]
        usage = completion.usage
        return LLMResponse(
            text=choice.message.content or "",
            tool_calls=calls,
            stop_reason="tool_use" if calls else (choice.finish_reason or "stop"),
            usage=priced(openai_usage(usage), self.prices),
        )

    async def chat_stream(
        self, messages: list[Message], tools: list[ToolDefinition] | None = None
    ) -> AsyncIterator[StreamEvent]:
        text: list[str] = []
        partial: dict[int, dict[str, str]] = {}
        names = tool_names(tools)
        try:
            stream = await self._client.chat.completions.create(
                **self.request(messages, tools, names), stream=True
            )
            async for chunk in stream:
                if not chunk.choices:
                    continue
                delta = chunk.choices[0].delta
                if delta.content:
                    text.append(delta.content)
                    yield StreamEvent(delta=delta.content)
                for tc in delta.tool_calls or []:
                    slot = partial.setdefault(tc.index, {"id": "", "name": "", "arguments": ""})
                    slot["id"] = tc.id or slot["id"]
                    if tc.function is not None:
                        slot["name"] += tc.function.name or ""
                        slot["arguments"] += tc.function.arguments or ""
        except openai.OpenAIError as exc:
            raise LLMError(f"{self.model}: {type(exc).__name__}: {exc}") from exc
        calls = [
            ToolCall(id=s["id"], name=names.app(s["name"]), arguments=_arguments(s["arguments"]))
            for _, s in sorted(partial.items())
        ]
        yield StreamEvent(
            response=LLMResponse(
                text="".join(text), tool_calls=calls, stop_reason="tool_use" if calls else "stop"
            )
        )

    async def aclose(self) -> None:
        await self._client.close()
