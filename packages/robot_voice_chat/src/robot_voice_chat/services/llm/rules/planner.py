"""RulesPlanner: the offline planner behind the LLMProvider port (``llm_planner=rules``).

Deterministic and honestly named: it understands the commands of :mod:`.commands`, plans
them over the tools it is given and drives the executor with the same local tools an LLM
uses (set_plan / update_plan / say / wait_for_events / finish_mission). Each conversation
(one mission) gets a :class:`MissionProgram`; a conversation begun by another planner (the
cloud one failed, :mod:`..chain`) is taken over from where it is. The request is read against the
live places: the first step lists them (``navigation.list_locations``), so "go to the kitchen
and then to reception" or "your charger" resolve before the plan is made. A distillation request
(teaching, no tools, "Mission transcript:") is answered by the template distiller.
"""

from __future__ import annotations

import time
from collections import OrderedDict
from collections.abc import AsyncIterator
from dataclasses import dataclass, field, replace

import structlog

from robot_language.commands import parse
from robot_language.places import PlaceIndex
from robot_language.recall import Recall
from robot_language.understand import Understanding
from robot_voice_chat.services.llm.base import (
    LLMProvider,
    LLMResponse,
    Message,
    StreamEvent,
    ToolCall,
    ToolDefinition,
    ToolResult,
)
from robot_voice_chat.services.llm.rules.distiller import TRANSCRIPT_HEADER, distill
from robot_voice_chat.services.llm.rules.driving import NAVIGATE
from robot_voice_chat.services.llm.rules.legs import legs_of
from robot_voice_chat.services.llm.rules.program import (
    LIST_LOCATIONS,
    TASK_EVENT,
    MissionProgram,
    Settings,
)
from robot_voice_chat.services.llm.rules.recall_program import recall_program
from robot_voice_chat.services.llm.rules.recollection import names_of
from robot_voice_chat.services.llm.rules.steps import Act, Call, Observation, Program
from robot_voice_chat.services.llm.rules.surface import has_tool, task_id_of

logger = structlog.get_logger(__name__)
PAUSED_MARK = "mission is paused"


@dataclass
class _Session:
    instruction: str
    tools: list[ToolDefinition]
    resumed: bool
    seen: int
    program: Program | None = None  # made once the live places are read
    pending: list[ToolCall] = field(default_factory=list)
    calls: int = 0
    serial: int = 0
    # drives this conversation started (also by a planner it took over from) still running
    own_drives: set[str] = field(default_factory=set)
    answered: list[str] | None = None  # the tools of our last answer (None: none given yet)


def _continues(session: _Session, messages: list[Message]) -> bool:
    """Whether ``messages`` is the session's conversation: our last answer is in it, where
    we gave it (a gateway may rename call ids, so the tools are compared, in order)."""
    if session.answered is None:
        return session.seen <= len(messages)
    if len(messages) < session.seen:
        return False
    ours = messages[session.seen - 1]
    return ours.role == "assistant" and [c.name for c in ours.tool_calls] == session.answered


def _instruction(messages: list[Message]) -> Message | None:
    return next((m for m in messages if m.role == "user" and m.content), None)


def _observe(session: _Session, new: list[Message]) -> Observation:
    """What came back since our last answer: the results of our calls (by id, or in order
    when a gateway renamed the ids), the event and user lines, a paused-mission reply."""
    returned = [r for m in new if m.role == "user" for r in m.tool_results]
    by_id = {r.tool_call_id: r for r in returned}
    if session.pending and not any(c.id in by_id for c in session.pending):
        by_id = {c.id: r for c, r in zip(session.pending, returned, strict=False)}
    results = [
        by_id.get(c.id)
        or ToolResult(tool_call_id=c.id, content="no result came back", is_error=True)
        for c in session.pending
    ]
    observation = Observation(results=results)
    for message in new:
        if message.role != "user" or not message.content:
            continue
        if PAUSED_MARK in message.content and "User:" in message.content:
            observation.paused_reply = message.content.rsplit("User:", 1)[1].strip()
        observation.lines += [line for line in message.content.splitlines() if line.strip()]
    return observation


class RulesPlanner(LLMProvider):
    name = "rules"

    def __init__(
        self,
        prewarm: bool = True,
        eta_trigger_s: float = 10.0,
        find_timeout_s: float = 20.0,
        max_legs: int = 6,
        max_sessions: int = 16,
        understanding: Understanding | None = None,
    ) -> None:
        self.understanding = understanding or Understanding()
        self.settings = Settings(prewarm, eta_trigger_s, find_timeout_s, max_legs)
        self._sessions: OrderedDict[str, _Session] = OrderedDict()
        self._max_sessions = max_sessions
        self._serial = 0

    @property
    def understanding_label(self) -> str:
        return "rules + embedded matcher"

    async def chat(
        self, messages: list[Message], tools: list[ToolDefinition] | None = None
    ) -> LLMResponse:
        started = time.monotonic()
        if not tools and messages and messages[-1].content.startswith(TRANSCRIPT_HEADER):
            return LLMResponse(text=distill(messages[-1].content))
        instruction = _instruction(messages)
        if instruction is None:
            return LLMResponse(text="I need an instruction to plan.")
        session = self._session(instruction, messages, list(tools or []))
        observation = _observe(session, messages[session.seen :])
        act = self._next(session, observation)
        response = self._respond(session, act)
        session.seen = len(messages) + 1  # the executor appends this answer next
        logger.debug(
            "rules_planner_step",
            tool_calls=[c.name for c in response.tool_calls],
            duration_ms=round((time.monotonic() - started) * 1000, 2),
        )
        return response

    def _session(
        self, instruction: Message, messages: list[Message], tools: list[ToolDefinition]
    ) -> _Session:
        # One mission = one conversation: the same instruction, and it only ever grows past
        # our last answer. The same words in a new conversation (a new mission) start afresh:
        # what failed before (a server down) may work now.
        key = instruction.content
        session = self._sessions.get(key)
        if session is not None and _continues(session, messages):
            return session
        resumed = any(m.role == "assistant" and m.tool_calls for m in messages)
        self._serial += 1
        session = _Session(
            key,
            tools,
            resumed,
            seen=len(messages),
            serial=self._serial,
            own_drives=_drives_started(messages),
        )
        self._sessions[key] = session
        while len(self._sessions) > self._max_sessions:
            self._sessions.popitem(last=False)
        return session

    def _next(self, session: _Session, observation: Observation) -> Act:
        """The program's next step; before the first, the live places are listed and read."""
        if session.program is not None:
            return session.program.send(observation)
        listing = has_tool(session.tools, LIST_LOCATIONS)
        if listing and session.calls == 0:
            return Act([Call(LIST_LOCATIONS)])
        listed = observation.results[0] if listing and observation.results else None
        places = None
        if listed is not None and not listed.is_error:
            places = self.understanding.places(listed.content)
        session.program = self._program(session, places, listed)
        return next(session.program)

    def _program(
        self, session: _Session, places: PlaceIndex | None, listed: ToolResult | None
    ) -> Program:
        reading = self.understanding.understand(session.instruction, places)
        if reading.kind == "answer" and reading.recall is not None:
            logger.info("rules_planner_recall", tool=reading.recall.tool, resumed=session.resumed)
            recall = _on_the_map(reading.recall, places)
            names = names_of(places)  # the places said by their human names, as the chat does
            return recall_program(recall, session.tools, session.resumed, names)
        legs, refusal = legs_of(reading, session.instruction)
        logger.info(
            "rules_planner_mission",
            understood=[leg.describe() for leg in legs] or reading.code(),
            stage=reading.stage,
            resumed=session.resumed,
            places=places is not None,
        )
        return MissionProgram(
            legs or [parse(session.instruction)],
            session.tools,
            self.settings,
            session.resumed,
            refusal,
            listed=None if listed is None or listed.is_error else listed.content,
            own_drives=session.own_drives,
        ).run()

    def _respond(self, session: _Session, act: Act) -> LLMResponse:
        calls = []
        for call in act.calls:
            session.calls += 1
            calls.append(_tool_call(call, f"rules_{session.serial}_{session.calls}"))
        session.pending = calls
        session.answered = [c.name for c in calls]
        return LLMResponse(text=act.text, tool_calls=calls, stop_reason="tool_use")

    async def chat_stream(
        self, messages: list[Message], tools: list[ToolDefinition] | None = None
    ) -> AsyncIterator[StreamEvent]:
        yield StreamEvent(response=await self.chat(messages, tools))


def _drives_started(messages: list[Message]) -> set[str]:
    """Task ids of the drives this conversation started (by any planner) and not seen end."""
    calls = {
        c.id for m in messages if m.role == "assistant" for c in m.tool_calls if c.name == NAVIGATE
    }
    started = {
        task_id
        for m in messages
        for r in m.tool_results
        if r.tool_call_id in calls and not r.is_error and (task_id := task_id_of(r.content))
    }
    ended = {
        match["id"]
        for m in messages
        if m.role == "user"
        for line in m.content.splitlines()
        if (match := TASK_EVENT.match(line.strip())) is not None and match["kind"] != "watch_event"
    }
    return started - ended


def _on_the_map(recall: Recall, places: PlaceIndex | None) -> Recall:
    """The place asked about as its map id when the live list knows it for sure ("Alice's
    desk" → desk_alice); else as said (the episodic server resolves it or says it is unknown)."""
    if recall.place is None or places is None or not places.places:
        return recall
    match = places.resolve(recall.place)
    if not match.sure:
        return recall
    arguments = {**recall.arguments, "place": match.names[0]}
    return replace(recall, arguments=arguments, place=match.names[0])


def _tool_call(call: Call, call_id: str) -> ToolCall:
    return ToolCall(id=call_id, name=call.name, arguments=dict(call.arguments))
