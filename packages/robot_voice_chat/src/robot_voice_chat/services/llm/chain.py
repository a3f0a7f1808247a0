"""PlannerChain: the cloud planner first, the next provider (the rules planner) when it fails.

When a provider raises :class:`LLMError` (network, 5xx, 401, timeout, after the SDK's own
retries) the same conversation continues on the next one for the rest of the mission, and the
person is told once (a ``say`` call put in front of the fallback's answer). ``degraded`` is
true while the last conversation runs on a fallback (readyz reports it); the next mission
(a new conversation) tries the first provider again.
"""

from __future__ import annotations

from collections.abc import AsyncIterator

import structlog

from robot_voice_chat.services.llm.base import (
    LLMError,
    LLMProvider,
    LLMResponse,
    Message,
    StreamEvent,
    ToolCall,
    ToolDefinition,
)

logger = structlog.get_logger(__name__)
NOTICE = (
    "I've lost my connection to the cloud planner, so I'll carry on with my basic offline commands."
)


def _conversation(messages: list[Message]) -> str:
    return next((m.content for m in messages if m.role == "user" and m.content), "")


class PlannerChain(LLMProvider):
    def __init__(self, providers: list[LLMProvider], notice: str = NOTICE) -> None:
        if not providers:
            raise ValueError("the planner chain needs at least one provider")
        self.providers = list(providers)
        self.notice = notice
        self.name = "chain[" + ",".join(p.name for p in self.providers) + "]"
        self.degraded = False
        self.last_error = ""
        self._key: str | None = None
        self._length = 0
        self._index = 0
        self._told = False
        self._notices = 0

    @property
    def understanding_label(self) -> str:
        """ "anthropic, fallback rules + embedded matcher"; the active one first when degraded."""
        first, *rest = (p.understanding_label for p in self.providers)
        if self.degraded:
            return f"{self.providers[self._index].understanding_label} (fallback: {first} failed)"
        return ", fallback ".join([first, *rest])

    def _select(self, messages: list[Message]) -> None:
        key = _conversation(messages)
        if key != self._key or len(messages) < self._length:
            self._key, self._index, self._told = key, 0, False  # a new mission: cloud first
        self._length = len(messages)

    async def chat(
        self, messages: list[Message], tools: list[ToolDefinition] | None = None
    ) -> LLMResponse:
        self._select(messages)
        while True:
            provider = self.providers[self._index]
            try:
                response = await provider.chat(messages, tools)
            except LLMError as exc:
                if self._index == len(self.providers) - 1:
                    raise
                self._index += 1
                self.degraded, self.last_error = True, str(exc)[:300]
                logger.warning(
                    "planner_degraded",
                    failed=provider.name,
                    fallback=self.providers[self._index].name,
                    error=self.last_error,
                )
                continue
            if self._index == 0:
                self.degraded = False
                return response
            return self._tell_once(response, tools)

    def _tell_once(self, response: LLMResponse, tools: list[ToolDefinition] | None) -> LLMResponse:
        if self._told or not any(t.name == "say" for t in tools or []):
            return response
        self._told = True
        self._notices += 1
        say = ToolCall(
            id=f"chain_notice_{self._notices}", name="say", arguments={"text": self.notice}
        )
        return response.model_copy(
            update={"tool_calls": [say, *response.tool_calls], "stop_reason": "tool_use"}
        )

    async def chat_stream(
        self, messages: list[Message], tools: list[ToolDefinition] | None = None
    ) -> AsyncIterator[StreamEvent]:
        response = await self.chat(messages, tools)
        if response.text:
            yield StreamEvent(delta=response.text)
        yield StreamEvent(response=response)

    async def aclose(self) -> None:
        for provider in self.providers:
            await provider.aclose()
