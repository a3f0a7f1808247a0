"""RulesChat: the offline fast path (``llm=rules``). Greetings and "what can you do" are
answered, "stop" calls stop_mission, a command the rules planner understands is handed to
start_mission, anything else gets an honest "I can't do that offline"."""

from __future__ import annotations

import re
from collections.abc import AsyncIterator

from robot_voice_chat.services.llm.base import (
    LLMProvider,
    LLMResponse,
    Message,
    StreamEvent,
    ToolCall,
    ToolDefinition,
)
from robot_voice_chat.services.llm.rules.commands import Command, normalise, parse
from robot_voice_chat.services.llm.rules.program import UNDERSTOOD

_GREETING = re.compile(r"^(?:hi|hello|hey|hallo|good (?:morning|afternoon|evening)|howdy)\b")
_HELP = re.compile(r"\b(?:what can you do|help|what do you understand|who are you)\b")
_STOP = re.compile(r"^(?:stop|halt|freeze|stopp|arrête|fermati)\b")
INTRO = (
    "I'm the robot's offline voice (rules, no language model): I understand simple commands — "
    f"{UNDERSTOOD}. Say stop to halt me."
)


def ack(command: Command) -> str:
    if command.kind == "goto":
        return f"On my way to the {command.place}."
    if command.kind == "fetch":
        return f"On my way to the {command.place} to get the {command.obj}."
    if command.kind == "find":
        return f"I'll look for the {command.obj}."
    if command.kind == "watch":
        return f"I'll watch for {command.obj}."
    return "Let me look."


class RulesChat(LLMProvider):
    name = "rules"

    def __init__(self) -> None:
        self._ids = 0

    async def chat(
        self, messages: list[Message], tools: list[ToolDefinition] | None = None
    ) -> LLMResponse:
        last = messages[-1] if messages else Message(role="user")
        if last.tool_results:  # the answer to our own stop_mission / tool call
            failed = [r.content for r in last.tool_results if r.is_error]
            return LLMResponse(text=f"That didn't work: {failed[0]}" if failed else "Done.")
        text = normalise(last.content)
        names = {t.name for t in tools or []}
        if _STOP.match(text) and "stop_mission" in names:
            return self._call("stop_mission", {})
        if _GREETING.match(text) and len(text.split()) <= 4:
            return LLMResponse(text=f"Hello! {INTRO}")
        if _HELP.search(text):
            return LLMResponse(text=INTRO)
        command = parse(last.content)
        if command.kind != "unknown" and "start_mission" in names:
            return self._call(
                "start_mission", {"instruction": last.content.strip(), "ack": ack(command)}
            )
        return LLMResponse(
            text=f"I can't do that offline: I didn't understand {last.content.strip()!r}. {INTRO}"
        )

    def _call(self, name: str, arguments: dict[str, str]) -> LLMResponse:
        self._ids += 1
        call = ToolCall(id=f"rules_chat_{self._ids}", name=name, arguments=arguments)
        return LLMResponse(tool_calls=[call], stop_reason="tool_use")

    async def chat_stream(
        self, messages: list[Message], tools: list[ToolDefinition] | None = None
    ) -> AsyncIterator[StreamEvent]:
        response = await self.chat(messages, tools)
        words = re.findall(r"\S+\s*", response.text)
        for word in words:
            yield StreamEvent(delta=word)
        yield StreamEvent(response=response)
