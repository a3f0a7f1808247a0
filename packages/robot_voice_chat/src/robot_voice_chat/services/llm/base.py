"""The LLM port: one chat call (with tools) and its streaming twin, plus the message DTOs."""

from __future__ import annotations

import abc
from collections.abc import AsyncIterator
from typing import Any, Literal

from pydantic import BaseModel, Field

Role = Literal["system", "user", "assistant"]


class ToolDefinition(BaseModel):
    """A tool the model may call; ``parameters`` is a JSON schema object."""

    name: str
    description: str = ""
    parameters: dict[str, Any] = Field(default_factory=lambda: {"type": "object", "properties": {}})
    # the server's MCP tool annotations (readOnlyHint, destructiveHint, ...); None = none given
    annotations: dict[str, Any] | None = None


class ToolCall(BaseModel):
    id: str
    name: str
    arguments: dict[str, Any] = Field(default_factory=dict)


HELD_BY_SAFETY_STOP = "HELD_BY_SAFETY_STOP"
USER_TURN_PREFIX = "[user] "
"""How the executor hands a person's mid-mission turn to the planner (one line each)."""
"""The error code of a motion tool call the brain held, never sent, because a safety stop
waits for the person's answer (agent/dispatch.py); planners treat it as a pause."""


class ToolResult(BaseModel):
    """The answer to one tool call; failures are values (``is_error``), never exceptions."""

    tool_call_id: str
    content: str
    is_error: bool = False
    # the call went out and its server went away or stayed silent: it may have started
    # (``ToolOutcome.cut_off``; never sent to a model, only read by the rules planner)
    cut_off: bool = False


class Message(BaseModel):
    role: Role
    content: str = ""
    tool_calls: list[ToolCall] = Field(default_factory=list)
    tool_results: list[ToolResult] = Field(default_factory=list)
    # Vendor blocks an adapter must send back verbatim (e.g. Anthropic thinking blocks).
    provider_blocks: list[dict[str, Any]] | None = None


class Usage(BaseModel):
    input_tokens: int = 0
    output_tokens: int = 0
    cache_read_tokens: int = 0
    cache_write_tokens: int = 0
    cost_usd: float | None = None

    def __add__(self, other: Usage) -> Usage:
        """Totals (a mission's); the cost is known if any part of it is."""
        costs = [c for c in (self.cost_usd, other.cost_usd) if c is not None]
        return Usage(
            input_tokens=self.input_tokens + other.input_tokens,
            output_tokens=self.output_tokens + other.output_tokens,
            cache_read_tokens=self.cache_read_tokens + other.cache_read_tokens,
            cache_write_tokens=self.cache_write_tokens + other.cache_write_tokens,
            cost_usd=round(sum(costs), 8) if costs else None,
        )


class LLMResponse(BaseModel):
    text: str = ""
    tool_calls: list[ToolCall] = Field(default_factory=list)
    stop_reason: str = "end_turn"
    usage: Usage = Field(default_factory=Usage)
    provider_blocks: list[dict[str, Any]] | None = None

    @property
    def has_tool_calls(self) -> bool:
        return bool(self.tool_calls)

    def as_message(self) -> Message:
        return Message(
            role="assistant",
            content=self.text,
            tool_calls=list(self.tool_calls),
            provider_blocks=self.provider_blocks,
        )


class StreamEvent(BaseModel):
    """One item of ``chat_stream``: a text delta, or the final response (last item)."""

    delta: str = ""
    response: LLMResponse | None = None


class LLMError(RuntimeError):
    """A provider failed for good (after its retries): the caller reports it, never hangs."""


class LLMProvider(abc.ABC):
    """Port for chat models. Adapters map vendor errors to :class:`LLMError`."""

    name: str = "llm"

    @property
    def understanding_label(self) -> str:
        """What reads the operator's words, for the status bar ("rules + embedded matcher")."""
        return self.name

    @abc.abstractmethod
    async def chat(
        self, messages: list[Message], tools: list[ToolDefinition] | None = None
    ) -> LLMResponse: ...

    @abc.abstractmethod
    def chat_stream(
        self, messages: list[Message], tools: list[ToolDefinition] | None = None
    ) -> AsyncIterator[StreamEvent]: ...

    async def aclose(self) -> None:  # noqa: B027 - optional hook
        """Release network clients; adapters without any keep the default."""
