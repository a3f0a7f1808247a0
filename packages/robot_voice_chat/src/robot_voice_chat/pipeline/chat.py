"""The single-turn fast path: user turn → fast LLM (+ MCP and local tools) → streamed reply.

While a mission is active every turn is routed into the mission (§5.1).
"""

from __future__ import annotations

import asyncio
import time
import uuid
from collections.abc import AsyncIterator
from dataclasses import dataclass
from typing import Literal

import structlog

from robot_voice_chat.agent.executor import MissionExecutor
from robot_voice_chat.agent.mission import Mission
from robot_voice_chat.agent.run import MissionBusyError, MissionsDisabledError
from robot_voice_chat.control.latch import acting
from robot_voice_chat.pipeline.fast_tools import FAST_LOCAL_TOOLS
from robot_voice_chat.robot_words import plain_instruction
from robot_voice_chat.services.emitter.base import EventEmitter
from robot_voice_chat.services.llm.base import (
    LLMError,
    LLMProvider,
    LLMResponse,
    Message,
    ToolCall,
    ToolDefinition,
    ToolResult,
)
from robot_voice_chat.services.speech.base import SpeechOutput
from robot_voice_chat.services.tools.base import ToolBackend
from robot_voice_chat.settings import ChatConfig
from robot_voice_chat.socket_events import ChatDelta, ChatError, ChatMessage

logger = structlog.get_logger(__name__)
Route = Literal["fast", "mission", "mission_started", "error", "stopped"]


@dataclass
class TurnResult:
    turn_id: str
    reply: str
    route: Route
    mission_id: str | None = None


def busy_message(mission: Mission, offer_stop: bool = True) -> str:
    """One sentence; ``offer_stop``: every motion server answers, so a stop halts the robot
    (issue 27)."""
    how = "; say stop to halt me, or abort to end it" if offer_stop else ""
    doing = f"{plain_instruction(mission.instruction)}; it is {mission.state}"
    return f"I'm busy with a mission right now ({doing}){how}."


class ChatPipeline:
    def __init__(
        self,
        *,
        llm: LLMProvider,
        tools: ToolBackend,
        executor: MissionExecutor,
        emitter: EventEmitter,
        speech: SpeechOutput,
        config: ChatConfig,
    ) -> None:
        self._llm = llm
        self._tools = tools
        self._executor = executor
        self._emitter = emitter
        self._speech = speech
        self._config = config
        self._history: list[Message] = []
        self._fast_turns: set[asyncio.Task[TurnResult]] = set()
        # (mission id, monotonic time) of the last busy reply said aloud: once per burst
        self._busy_said: tuple[str, float] | None = None

    async def handle_turn(self, text: str, turn_id: str | None = None) -> TurnResult:
        turn_id = turn_id or uuid.uuid4().hex[:8]
        with structlog.contextvars.bound_contextvars(turn_id=turn_id):
            started = time.monotonic()
            await self._emitter.emit(ChatMessage(turn_id=turn_id, role="user", text=text))
            result = await self._route(text, turn_id)
            logger.info(
                "turn_handled",
                route=result.route,
                duration_ms=round((time.monotonic() - started) * 1000, 1),
            )
            return result

    async def stop(self, reason: str = "Stop (operator request)") -> str:
        """``stop_pipeline`` / stop_mission / ``POST /api/safety/stop``: end streaming replies,
        safety stop (latched until an operator clears it), then quiet. Returns what the
        person is told; a stop some motion server did not confirm is said even without a
        mission (a paused mission says it itself)."""
        current = asyncio.current_task()
        for turn in list(self._fast_turns):
            if turn is not current:  # stop_mission called from inside a turn ends the rest
                turn.cancel()
        mission = self._executor.active
        told = await self._executor.safety_stop(reason=reason)
        if mission is None and told != "Stopped.":
            turn_id = uuid.uuid4().hex[:8]
            await self._emitter.emit(ChatMessage(turn_id=turn_id, role="assistant", text=told))
        return told

    async def _route(self, text: str, turn_id: str) -> TurnResult:
        mission = self._executor.active
        note = await self._executor.on_user_turn(text) if mission is not None else None
        if mission is not None and note is not None:
            # shown at once (not spoken: the planner may answer with its own say)
            await self._emitter.emit(ChatMessage(turn_id=turn_id, role="assistant", text=note))
            return TurnResult(turn_id, note, "mission", mission.id)
        answered = self._answer_approval(text)
        if answered is not None:
            await self._emitter.emit(ChatMessage(turn_id=turn_id, role="assistant", text=answered))
            return TurnResult(turn_id, answered, "fast")
        turn = asyncio.create_task(self._fast_turn(text, turn_id), name=f"turn-{turn_id}")
        self._fast_turns.add(turn)
        try:
            return await turn
        except asyncio.CancelledError:
            task = asyncio.current_task()
            if task is not None and task.cancelling():
                raise  # our caller is cancelled, not the reply
            await self._emitter.emit(
                ChatMessage(turn_id=turn_id, role="assistant", text="Stopped.")
            )
            return TurnResult(turn_id, "", "stopped")
        except LLMError as exc:
            logger.warning("fast_path_failed", error=str(exc))
            message = "Sorry, I can't answer right now: my language model is not answering."
            await self._emitter.emit(ChatError(turn_id=turn_id, message=message))
            return TurnResult(turn_id, message, "error")
        finally:
            self._fast_turns.discard(turn)

    def _answer_approval(self, text: str) -> str | None:
        """A yes/no to an approval a fast-path call waits for (not a stop: stops stop)."""
        approvals = self._executor.approvals
        if approvals is None or self._executor.is_stop(text):
            return None
        return approvals.answer_from_chat(text, None, acting())

    def _fast_path_may_call(self, name: str) -> bool:
        """Motion reaches the robot only through a mission (start_mission), so the fast path
        sees a motion server's read-only tools alone (``chat.motion_read_tools``)."""
        server, _, tool = name.partition(".")
        cfg = self._tools.servers().get(server)
        return cfg is None or not cfg.motion or tool in self._config.motion_read_tools

    async def _fast_turn(self, text: str, turn_id: str) -> TurnResult:
        keep = self._config.history_turns * 2
        messages = [
            Message(role="system", content=self._config.system_prompt),
            *(self._history[-keep:] if keep else []),
            Message(role="user", content=text),
        ]
        tools = FAST_LOCAL_TOOLS + [
            t for t in self._tools.list_tools() if self._fast_path_may_call(t.name)
        ]
        reply = ""
        for _ in range(self._config.max_tool_rounds):
            response = await self._stream_reply(messages, tools, turn_id)
            reply += response.text
            messages.append(response.as_message())
            if not response.tool_calls:
                break
            results, handoff = [], None
            for call in response.tool_calls:
                result, started = await self._call(call, turn_id)
                results.append(result)
                handoff = handoff or started
            messages.append(Message(role="user", tool_results=results))
            if handoff is not None:
                self._remember(text, handoff.reply)
                return handoff
        await self._emitter.emit(ChatMessage(turn_id=turn_id, role="assistant", text=reply))
        self._remember(text, reply)
        return TurnResult(turn_id, reply, "fast")

    async def _stream_reply(
        self, messages: list[Message], tools: list[ToolDefinition], turn_id: str
    ) -> LLMResponse:
        final: LLMResponse | None = None

        async def deltas() -> AsyncIterator[str]:
            nonlocal final
            async for event in self._llm.chat_stream(messages, tools):
                if event.response is not None:
                    final = event.response
                elif event.delta:
                    await self._emitter.emit(ChatDelta(turn_id=turn_id, text=event.delta))
                    yield event.delta

        await self._speech.say_stream(deltas())
        if final is None:
            raise LLMError("the fast-path stream ended without a final response")
        return final

    async def _call(self, call: ToolCall, turn_id: str) -> tuple[ToolResult, TurnResult | None]:
        if call.name == "start_mission":
            return await self._start_mission(call, turn_id)
        if call.name == "stop_mission":
            told = await self.stop("Stop (asked in chat)")
            return ToolResult(tool_call_id=call.id, content=told), None
        if call.name == "resume_mission":  # no mission runs here: the turn would have gone to it
            return ToolResult(
                tool_call_id=call.id, content=self._executor.nothing_to_resume()
            ), None
        if not self._fast_path_may_call(call.name):
            logger.warning("fast_path_motion_refused", tool=call.name)
            text = f"{call.name} moves the robot: call start_mission for physical tasks."
            return ToolResult(tool_call_id=call.id, content=text, is_error=True), None
        outcome = await self._tools.call_tool(call.name, call.arguments)
        self._executor.skills.note(call.name, call.arguments, outcome.text, outcome.is_error)
        return ToolResult(
            tool_call_id=call.id, content=outcome.text, is_error=outcome.is_error
        ), None

    async def _start_mission(self, call: ToolCall, turn_id: str) -> tuple[ToolResult, TurnResult]:
        instruction = str(call.arguments.get("instruction", "")).strip()
        ack = str(call.arguments.get("ack", "")).strip() or "On it."
        busy: Mission | None = None
        try:
            if not instruction:
                raise ValueError("I need to know what to do")
            mission = await self._executor.start(instruction)
        except MissionBusyError as exc:
            supervisor = self._executor.supervisor
            busy = exc.mission
            reply = busy_message(busy, supervisor is None or supervisor.all_fresh())
            route: Route = "error"
            mission_id = None
        except (MissionsDisabledError, ValueError) as exc:
            reply, route, mission_id = f"I can't start a mission: {exc}", "error", None
        else:
            reply, route, mission_id = ack, "mission_started", mission.id
        await self._emitter.emit(ChatMessage(turn_id=turn_id, role="assistant", text=reply))
        if busy is None or self._say_busy(busy):
            await self._speech.say(reply)
        result = ToolResult(tool_call_id=call.id, content=reply, is_error=route == "error")
        return result, TurnResult(turn_id, reply, route, mission_id)

    def _say_busy(self, mission: Mission) -> bool:
        """Whether this busy reply is said aloud: the first of a burst for ``mission`` is,
        the rest are only shown (twenty messages at once must not make the robot say the
        same thing fifteen times)."""
        now = time.monotonic()
        said = self._busy_said
        repeat_s = self._config.busy_reply_repeat_s
        if said is not None and said[0] == mission.id and now - said[1] < repeat_s:
            logger.info("busy_reply_not_repeated", mission_id=mission.id)
            return False
        self._busy_said = (mission.id, now)
        return True

    def _remember(self, user: str, reply: str) -> None:
        self._history += [
            Message(role="user", content=user),
            Message(role="assistant", content=reply),
        ]
