"""A scripted fake LLM for tests and benchmarks: replies come from a list or a function."""

from __future__ import annotations

import asyncio
from collections.abc import AsyncIterator, Callable
from typing import Any

from robot_voice_chat.services.llm.base import (
    LLMError,
    LLMProvider,
    LLMResponse,
    Message,
    StreamEvent,
    ToolCall,
    ToolDefinition,
)

Script = Callable[[list[Message], list[ToolDefinition]], "LLMResponse | Any"]


def reply(text: str = "", *calls: tuple[str, dict[str, Any]]) -> LLMResponse:
    """Shorthand: ``reply("ok", ("set_plan", {...}))`` — tool-call ids are assigned later."""
    return LLMResponse(
        text=text,
        tool_calls=[ToolCall(id="", name=name, arguments=args) for name, args in calls],
        stop_reason="tool_use" if calls else "end_turn",
    )


class FakeLLM(LLMProvider):
    """Plays ``responses`` in order (or calls ``script``) and records every request."""

    name = "fake"

    def __init__(
        self,
        responses: list[LLMResponse | Exception] | None = None,
        script: Callable[[list[Message], list[ToolDefinition]], LLMResponse] | None = None,
        gate: asyncio.Event | None = None,
        gate_on_call: int | None = None,
        record: bool = True,
    ) -> None:
        self._responses = list(responses or [])
        self._script = script
        self._gate = gate
        self._gate_on_call = gate_on_call
        self._record = record
        self.requests: list[tuple[list[Message], list[ToolDefinition]]] = []
        self._ids = 0

    async def chat(
        self, messages: list[Message], tools: list[ToolDefinition] | None = None
    ) -> LLMResponse:
        snapshot = [m.model_copy(deep=True) for m in messages] if self._record else []
        self.requests.append((snapshot, list(tools or [])))
        if self._gate is not None and self._gate_on_call in (None, len(self.requests)):
            await self._gate.wait()
        if self._script is not None:
            response = self._script(messages, list(tools or []))
        elif self._responses:
            item = self._responses.pop(0)
            if isinstance(item, Exception):
                raise item
            response = item
        else:
            raise LLMError("FakeLLM has no scripted response left")
        calls = []
        for call in response.tool_calls:
            self._ids += 1
            calls.append(call if call.id else call.model_copy(update={"id": f"call-{self._ids}"}))
        return response.model_copy(update={"tool_calls": calls})

    async def chat_stream(
        self, messages: list[Message], tools: list[ToolDefinition] | None = None
    ) -> AsyncIterator[StreamEvent]:
        response = await self.chat(messages, tools)
        for word in response.text.split(" ") if response.text else []:
            yield StreamEvent(delta=word + " ")
        yield StreamEvent(response=response)
