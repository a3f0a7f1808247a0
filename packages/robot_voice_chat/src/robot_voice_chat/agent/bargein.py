"""Barge-in (spec §9): halt motion first — no LLM in the path — then pause and ask."""

from __future__ import annotations

import asyncio
import re
from collections.abc import Callable
from typing import Any

import structlog

from robot_voice_chat.agent.dispatch import TaskDispatcher
from robot_voice_chat.agent.output import MissionOutput
from robot_voice_chat.agent.run import MissionRun
from robot_voice_chat.agent.supervision_words import unconfirmed_stop
from robot_voice_chat.agent.task_registry import TaskRegistry
from robot_voice_chat.agent.trace import TraceRecorder
from robot_voice_chat.control.approvals import ApprovalBroker
from robot_voice_chat.control.latch import SafetyLatch, acting
from robot_voice_chat.control.supervisor import MotionSupervisor
from robot_voice_chat.services.speech.base import SpeechOutput
from robot_voice_chat.services.tools.base import ToolBackend, ToolOutcome
from robot_voice_chat.settings import AgentConfig

logger = structlog.get_logger(__name__)
STOP_QUESTION = "Stopped. Should I continue or abort?"
LATCHED_QUESTION = "The software stop is latched. Should I continue or abort?"


class BargeIn:
    def __init__(
        self,
        *,
        tools: ToolBackend,
        registry: TaskRegistry,
        trace: TraceRecorder,
        config: AgentConfig,
        speech: SpeechOutput,
        output: MissionOutput,
        dispatcher: TaskDispatcher,
        current_run: Callable[[], MissionRun | None],
        latch: SafetyLatch,
        approvals: ApprovalBroker | None = None,
        supervisor: MotionSupervisor | None = None,
    ) -> None:
        self.tools = tools
        self.registry = registry
        self.trace = trace
        self.config = config
        self.speech = speech
        self.output = output
        self.dispatcher = dispatcher
        self.current_run = current_run
        self.latch = latch
        self.approvals = approvals
        self.supervisor = supervisor

    def is_stop(self, text: str) -> bool:
        """A stop word anywhere in the utterance stops — negations included ("don't stop"):
        a needless stop costs one question, a missed one costs a collision."""
        words = re.findall(r"[^\W\d_]+", text.lower())
        return any(word in self.config.stop_words for word in words)

    async def safety_stop(self, reason: str = "stop", by: str | None = None) -> str:
        """(0) latch the software stop and pause (state only, no await), (1) persist the
        latch while cancelling motion tasks +
        safety_stop_tool, (2) interrupt speech, (2b) end watchers and stop the vision skills
        the brain started, (3) mark their steps failed, (4) ask; the loop stays suspended
        until the user answers. Returns what the person is told: "Stopped. …" only when
        every motion server confirmed the stop; otherwise what is known of each one it could
        not reach (supervision_words)."""
        by = by or acting()
        self.latch.engage(by, reason)  # from here every motion call is refused (guard)
        if self.approvals is not None:  # nothing waiting for a yes may run after a stop
            self.approvals.deny_all(f"safety stop: {reason}")
        run = self.current_run()
        active = run is not None and run.mission.active
        if run is not None and active:
            # pause before any await: the loop starts no planner step, and a motion task whose
            # tool call is still in flight is cancelled by the dispatcher when it registers
            if run.llm_call is not None:
                run.llm_call.cancel()
            run.mission.state = "paused"
            run.suspended = True
            run.awaiting_user = True
        calls = [self._latch(by, reason)]
        cancelled = []
        stops: dict[str, Any] = {}
        for server in self.tools.servers().values():
            if not server.motion:
                continue
            for handle in self.registry.live(server=server.name):
                cancelled.append(self.registry.drop(handle.task_id) or handle)
                calls.append(self.dispatcher.cancel_task(server.name, handle.task_id))
            if server.safety_stop_tool:
                stops[server.name] = self._safety_tool(f"{server.name}.{server.safety_stop_tool}")
        results = await asyncio.gather(*calls, *stops.values())
        answers: list[ToolOutcome] = list(results[len(calls) :])
        unconfirmed = [name for name, out in zip(stops, answers, strict=True) if out.is_error]
        await self.speech.interrupt()
        watchers = [h for h in self.registry.live() if h.skill_id is not None]
        watched = {(h.skill_server, h.skill_id) for h in watchers}
        skills = [
            s for s in self.dispatcher.skills.active() if (s.server, s.skill_id) not in watched
        ]
        if run is not None and active:
            # a drive whose call had not answered is failed too (its task is cancelled when
            # the answer comes), so the paused plan shows no motion step still running
            in_flight = [run.mission.step(s) for s in self.dispatcher.motion_steps_in_flight]
            for step in in_flight:
                if step is not None:
                    step.set_status("failed", "safety stop")
            for handle in cancelled + watchers:
                step = run.mission.step(handle.step_id)
                if step is not None:
                    step.set_status("failed", "safety stop")
        await asyncio.gather(
            *(self.dispatcher.end_task(h) for h in watchers),
            *(self.dispatcher.stop_skill(s) for s in skills),
        )
        cancelled += watchers
        logger.warning(
            "safety_stop",
            reason=reason,
            cancelled=[h.task_id for h in cancelled],
            skills_stopped=[s.skill_id for s in skills] + [h.skill_id for h in watchers],
        )
        told = await self._told(unconfirmed)
        if run is None or not active:
            return told
        self.trace.record(
            run.mission.id, "safety_stop", reason=reason, cancelled=[h.task_id for h in cancelled]
        )
        await self.output.emit_plan(run)
        question = STOP_QUESTION if not unconfirmed else f"{told} {LATCHED_QUESTION}"
        await self.output.say(run, question)
        return question

    async def _told(self, unconfirmed: list[str]) -> str:
        if not unconfirmed:
            return "Stopped."
        said = [await unconfirmed_stop(self.supervisor, server) for server in unconfirmed]
        logger.warning("safety_stop_unconfirmed", servers=unconfirmed)
        return " ".join(said)

    async def _latch(self, by: str, reason: str) -> None:
        await self.latch.stop(by, reason)

    async def _safety_tool(self, tool: str) -> ToolOutcome:
        outcome = await self.tools.call_tool(tool, {}, self.config.tool_timeout_s)
        logger.info("safety_stop_tool_called", tool=tool, is_error=outcome.is_error)
        return outcome
