"""AnthropicLLM (spec §7): the planner adapter on the official ``anthropic`` SDK.

Request shape: adaptive thinking, ``output_config.effort``, ``max_tokens``; no temperature /
top_p / top_k / budget_tokens (they 400 on this model family). The system prompt goes to the
top-level ``system`` with ``cache_control`` (tools + system are the stable, cached prefix).
Retries (429/500/529, connection errors, timeouts) are the SDK's, bounded by ``max_retries``.
"""

from __future__ import annotations

from collections.abc import AsyncIterator
from typing import Any

import anthropic
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


def to_anthropic_messages(
    messages: list[Message], names: ToolNames | None = None
) -> list[dict[str, Any]]:
    """App messages → Anthropic ``messages`` (system excluded; same-role runs merged).

    Assistant turns the model produced go back verbatim (``provider_blocks``: thinking
    blocks unchanged, tool names as the model sent them); other tool names are encoded.
    """
    names = names or ToolNames()
    out: list[dict[str, Any]] = []
    for m in messages:
        if m.role == "system":
            continue
        blocks: list[dict[str, Any]] = []
        if m.role == "assistant" and m.provider_blocks:
            blocks = [dict(b) for b in m.provider_blocks]
        elif m.role == "assistant":
            if m.content:
                blocks.append({"type": "text", "text": m.content})
            blocks += [
                {"type": "tool_use", "id": c.id, "name": names.wire(c.name), "input": c.arguments}
                for c in m.tool_calls
            ]
        else:
            blocks += [
                {
                    "type": "tool_result",
                    "tool_use_id": r.tool_call_id,
                    "content": r.content,
                    "is_error": r.is_error,
                }
                for r in m.tool_results
            ]
            if m.content:
                blocks.append({"type": "text", "text": m.content})
        if not blocks:
            continue
        if out and out[-1]["role"] == m.role:
            out[-1]["content"] += blocks
        else:
            out.append({"role": m.role, "content": blocks})
    return out


def _block_param(block: Any) -> dict[str, Any] | None:
    kind = block.type
    if kind == "text":
        return {"type": "text", "text": block.text}
    if kind == "thinking":
        return {"type": "thinking", "thinking": block.thinking, "signature": block.signature}
    if kind == "redacted_thinking":
        return {"type": "redacted_thinking", "data": block.data}
    if kind == "tool_use":
        return {"type": "tool_use", "id": block.id, "name": block.name, "input": block.input}
    return None


def from_anthropic(
    message: Any, names: ToolNames | None = None, prices: Prices | None = None
) -> LLMResponse:
    names = names or ToolNames()
    text = "".join(b.text for b in message.content if b.type == "text")
    calls = [
        ToolCall(id=b.id, name=names.app(b.name), arguments=dict(b.input or {}))
        for b in message.content
        if b.type == "tool_use"
    ]
    blocks = [p for p in (_block_param(b) for b in message.content) if p is not None]
    usage = message.usage
    return LLMResponse(
        text=text,
        tool_calls=calls,
        stop_reason=message.stop_reason or "end_turn",
        usage=priced(
            Usage(
                input_tokens=usage.input_tokens or 0,
                output_tokens=usage.output_tokens or 0,
                cache_read_tokens=getattr(usage, "cache_read_input_tokens", None) or 0,
                cache_write_tokens=getattr(usage, "cache_creation_input_tokens", None) or 0,
            ),
            prices,
        ),
        provider_blocks=blocks,
    )


def tool_names(tools: list[ToolDefinition] | None) -> ToolNames:
    """The request's name map; a collision is a clear :class:`LLMError` before any call."""
    try:
        return ToolNames(t.name for t in tools or [])
    except ValueError as exc:
        raise LLMError(f"tool names: {exc}") from exc


class AnthropicLLM(LLMProvider):
    name = "anthropic"

    def __init__(
        self,
        api_key: str | SecretStr,
        model: str = "claude-opus-4-8",
        max_tokens: int = 16000,
        effort: str = "high",
        request_timeout_s: float = 120.0,
        max_retries: int = 2,
        base_url: str | None = None,
        prices: dict[str, float] | None = None,
    ) -> None:
        key = api_key if isinstance(api_key, SecretStr) else SecretStr(api_key or "")
        if not key.get_secret_value():
            raise ValueError("ANTHROPIC_API_KEY is empty but the anthropic adapter is selected")
        self.prices = Prices.parse(prices)
        self.model = model
        self.max_tokens = max_tokens
        self.effort = effort
        self._client = anthropic.AsyncAnthropic(
            api_key=key.get_secret_value(),
            base_url=base_url or None,  # "" from an empty env var = the default endpoint
            timeout=request_timeout_s,
            max_retries=max_retries,
        )

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
            "messages": to_anthropic_messages(messages, names),
            "thinking": {"type": "adaptive"},
            "output_config": {"effort": self.effort},
        }
        system = "\n\n".join(m.content for m in messages if m.role == "system" and m.content)
        if system:
            params["system"] = [
                {"type": "text", "text": system, "cache_control": {"type": "ephemeral"}}
            ]
        if tools:
            params["tools"] = [
                {
                    "name": names.wire(t.name),
                    "description": t.description,
                    "input_schema": t.parameters,
                }
                for t in tools
            ]
        return params

    async def chat(
        self, messages: list[Message], tools: list[ToolDefinition] | None = None
    ) -> LLMResponse:
        names = tool_names(tools)
        try:
            message = await self._client.messages.create(**self.request(messages, tools, names))
        except anthropic.APIError as exc:
            raise LLMError(f"anthropic: {type(exc).__name__}: {exc}") from exc
        return from_anthropic(message, names, self.prices)

    async def chat_stream(
        self, messages: list[Message], tools: list[ToolDefinition] | None = None
    ) -> AsyncIterator[StreamEvent]:
        names = tool_names(tools)
        try:
            async with self._client.messages.stream(
                **self.request(messages, tools, names)
            ) as stream:
                async for text in stream.text_stream:
                    yield StreamEvent(delta=text)
                final = await stream.get_final_message()
        except anthropic.APIError as exc:
            raise LLMError(f"anthropic: {type(exc).__name__}: {exc}") from exc
        yield StreamEvent(response=from_anthropic(final, names, self.prices))

    async def aclose(self) -> None:
        await self._client.close()
