"""Tool dispatch with step linkage (§5.3), task events + reactions (§5.4, §6), reconciliation."""

from __future__ import annotations

import asyncio
import json
import time
from collections import deque
from collections.abc import Callable, Coroutine
from typing import Any

import structlog

from robot_mcp_kit.models import TaskEvent
from robot_voice_chat.agent.lapse import IssuedCall, lost_link, refused_unsupervised
from robot_voice_chat.agent.output import MissionOutput
from robot_voice_chat.agent.perception_notice import FallbackNotice
from robot_voice_chat.agent.plan_tools import LOCAL_TOOLS, PlanTools, strip_step_id
from robot_voice_chat.agent.reactions import Reaction
from robot_voice_chat.agent.run import MissionRun
from robot_voice_chat.agent.server_links import ServerLinks
from robot_voice_chat.agent.skills import ActiveSkill, SkillLedger
from robot_voice_chat.agent.step_recovery import StepRecovery
from robot_voice_chat.agent.task_registry import (
    TERMINAL_EVENTS,
    TaskHandle,
    TaskRegistry,
    format_event,
    parse_task_info,
    progress_detail,
)
from robot_voice_chat.agent.trace import TraceRecorder
from robot_voice_chat.control.context import DispatchContext, dispatching
from robot_voice_chat.control.latch import SAFETY_STOP_LATCHED
from robot_voice_chat.control.supervisor import MotionSupervisor
from robot_voice_chat.services.llm.base import HELD_BY_SAFETY_STOP, ToolCall, ToolResult
from robot_voice_chat.services.tools.base import ToolBackend
from robot_voice_chat.settings import AgentConfig

logger = structlog.get_logger(__name__)
ORPHAN_GRACE_S = 30.0


def held_by_stop(run: MissionRun) -> bool:
    """A safety stop paused the mission and the person has not answered yet."""
    return run.mission.state == "paused" and run.awaiting_user


def held_error(tool: str) -> str:
    return json.dumps(
        {
            "error": HELD_BY_SAFETY_STOP,
            "detail": f"{tool} was not sent: a safety stop paused the mission. Wait for the "
            "person's answer; call it again only if they say to continue.",
        }
    )


def _short(args: dict[str, Any]) -> str:
    text = json.dumps(args, separators=(",", ":"), default=str)
    return text if len(text) <= 120 else text[:117] + "..."


class TaskDispatcher:
    """Runs the planner's tool calls, routes task events and cancels/reconciles tasks."""

    def __init__(
        self,
        *,
        tools: ToolBackend,
        registry: TaskRegistry,
        trace: TraceRecorder,
        config: AgentConfig,
        output: MissionOutput,
        plan_tools: PlanTools,
        current_run: Callable[[], MissionRun | None],
        latched: Callable[[], bool] = lambda: False,
        supervisor: MotionSupervisor | None = None,
    ) -> None:
        self.tools = tools
        self.registry = registry
        self.trace = trace
        self.config = config
        self.output = output
        self.plan_tools = plan_tools
        self.current_run = current_run
        self.skills = SkillLedger()
        self._background: set[asyncio.Task[None]] = set()
        # Events can overtake the tool result that names their task: keep them briefly.
        self.early_events: deque[tuple[float, TaskEvent]] = deque(maxlen=256)
        # steps whose motion tool call has not answered yet (a safety stop fails them too)
        self.motion_steps_in_flight: set[str] = set()
        # tasks of missions a previous process life left live (closed at start-up)
        self.interrupted: set[str] = set()
        self.fallback_notice = FallbackNotice()  # "I'm using the on-board detector", once
        self.latched = latched
        self.supervisor = supervisor
        # motion steps that lost a link for a moment with the brain alive (agent.lapse)
        self.recovery = StepRecovery(self)
        self.links = ServerLinks(self)  # losses, reconnects, orphan motion

    def spawn(self, coro: Coroutine[Any, Any, None]) -> None:
        task = asyncio.create_task(coro)
        self._background.add(task)
        task.add_done_callback(self._background.discard)

    def shutdown(self) -> None:
        for task in list(self._background):
            task.cancel()

    async def execute(self, run: MissionRun, call: ToolCall) -> ToolResult:
        if call.name in LOCAL_TOOLS:
            result = await self.plan_tools.call(run, call)
            self.trace.record(
                run.mission.id,
                "tool_result",
                tool=call.name,
                arguments=call.arguments,
                result=result.content[:2000],
                is_error=result.is_error,
            )
            return result
        step_id, args = strip_step_id(call.arguments)
        task_id = args.get("task_id")
        if isinstance(task_id, str):  # a task re-issued after a lapse goes by its new id
            args = {**args, "task_id": self.recovery.current_task_id(task_id)}
        mission = run.mission
        step = mission.step(step_id)
        server_cfg = self.tools.servers().get(call.name.partition(".")[0])
        motion = server_cfg is not None and server_cfg.motion
        if motion and held_by_stop(run):  # planned before the stop, executed after it
            return await self._refuse_held(run, call, step_id, args)
        if mission.state == "paused" and not run.awaiting_user:
            mission.state = "running"
        in_flight = step_id if motion else None
        if in_flight is not None:
            self.motion_steps_in_flight.add(in_flight)
        try:
            if step is not None:
                step.set_status("running")
                await self.output.emit_plan(run)
            await self.output.log_line(run, "tool_call", f"{call.name}({_short(args)})")
            if motion and held_by_stop(run):  # the stop came during the awaits above
                return await self._refuse_held(run, call, step_id, args)
            started, sent_at = time.monotonic(), time.time()
            latched_before = self.latched()
            # no await between the check above and the send: a stop cannot slip in between
            # (the guard behind call_tool re-checks the latch after any approval it waits for)
            with dispatching(DispatchContext(mission.id, step_id)):
                outcome = await self.tools.call_tool(call.name, args, self.config.tool_timeout_s)
        finally:
            if in_flight is not None:
                self.motion_steps_in_flight.discard(in_flight)
        if motion and refused_unsupervised(outcome):  # the lease lapsed a moment: nothing moved
            issued = IssuedCall(call.name, args, step_id)
            outcome = await self.recovery.resend_refused(run, issued, outcome)
        duration_ms = round((time.monotonic() - started) * 1000, 1)
        self.skills.note(call.name, args, outcome.text, outcome.is_error)
        self.trace.record(
            mission.id,
            "tool_result",
            tool=call.name,
            arguments=args,
            step_id=step_id,
            result=outcome.text[:2000],
            is_error=outcome.is_error,
            duration_ms=duration_ms,
        )
        logger.info(
            "tool_dispatched", tool=call.name, is_error=outcome.is_error, duration_ms=duration_ms
        )
        # the stop latched while the call was out, and the server refused it for that
        stopped = motion and not latched_before and self.latched()
        if stopped and outcome.is_error and SAFETY_STOP_LATCHED in outcome.text:
            return await self._stopped_in_flight(run, call, step_id)
        if motion and outcome.cut_off:  # its server went away mid-call: the motion may run
            await self.links.cut_off(run, call.name.partition(".")[0])
        if not outcome.is_error and (
            notice := self.fallback_notice.sentence_for(call.name, outcome.text)
        ):
            await self.output.say(run, notice)
        info = None if outcome.is_error else parse_task_info(outcome.text)
        if info is not None:
            if motion:
                self.recovery.issued[str(info["task_id"])] = IssuedCall(call.name, args, step_id)
            await self.register_task(run, call.name, step_id, info, sent_at)
        elif step is not None:
            step.set_status("failed" if outcome.is_error else "succeeded", outcome.text[:160])
            await self.output.emit_plan(run)
        return ToolResult(
            tool_call_id=call.id,
            content=outcome.text,
            is_error=outcome.is_error,
            cut_off=outcome.cut_off,
        )

    async def _refuse_held(
        self, run: MissionRun, call: ToolCall, step_id: str | None, args: dict[str, Any]
    ) -> ToolResult:
        """A motion call while a safety stop waits for the person's answer is never sent."""
        logger.warning("motion_call_held", tool=call.name, step_id=step_id)
        self.trace.record(
            run.mission.id, "tool_held", tool=call.name, arguments=args, step_id=step_id
        )
        held = await self._answer_held(run, call, step_id)
        await self.output.log_line(run, "tool_call", f"{call.name} held, not sent: safety stop")
        return held

    async def _stopped_in_flight(
        self, run: MissionRun, call: ToolCall, step_id: str | None
    ) -> ToolResult:
        """A motion call the server refused because the stop latched while it was on its way:
        the stop's doing, answered like a call held by the stop (the planner waits for the
        person's continue or abort), not a failure of the mission's own."""
        logger.warning("motion_call_stopped_in_flight", tool=call.name, step_id=step_id)
        return await self._answer_held(run, call, step_id)

    async def _answer_held(
        self, run: MissionRun, call: ToolCall, step_id: str | None
    ) -> ToolResult:
        """The step (if the stop has not marked it yet) fails "safety stop"; the planner gets
        the held answer and waits for the person's continue or abort."""
        step = run.mission.step(step_id)
        if step is not None and step.status == "running":
            step.set_status("failed", "safety stop")
            await self.output.emit_plan(run)
        return ToolResult(tool_call_id=call.id, content=held_error(call.name), is_error=True)

    async def register_task(
        self,
        run: MissionRun,
        dotted: str,
        step_id: str | None,
        info: dict[str, Any],
        sent_at: float,
        shown_as: str | None = None,
    ) -> None:
        server, _, tool = dotted.partition(".")
        # A watcher is started on skill_control but owned (events, cancel) by perception.
        owner = info.get("server")
        if not isinstance(owner, str) or owner not in self.tools.servers():
            owner = server
        skill_id = info.get("skill_id") if owner != server else None
        handle = TaskHandle(
            task_id=str(info["task_id"]),
            server=owner,
            tool=str(info.get("tool") or tool),
            step_id=step_id,
            mission_id=run.mission.id,
            skill_id=skill_id if isinstance(skill_id, str) else None,
            skill_server=server if isinstance(skill_id, str) else None,
            since=sent_at,
            shown_as=shown_as,
        )
        step = run.mission.step(step_id)
        if step is not None:
            step.task_id = handle.task_id
        server_cfg = self.tools.servers().get(owner)
        if run.mission.state == "paused" and server_cfg is not None and server_cfg.motion:
            # A safety stop came in while this call was in flight (the stop's cancel could not
            # see it): end it as the stop ends the others, its events orphans, not news.
            if step is not None:
                step.set_status("failed", "safety stop")
                await self.output.emit_plan(run)
            await self.cancel_task(owner, handle.task_id)
            return
        self.registry.register(handle)
        if step is not None:
            eta = info.get("est_duration_s")
            step.detail = f"ETA {eta:.0f} s" if isinstance(eta, int | float) else "running"
            await self.output.emit_plan(run)
        now = time.monotonic()
        early = [
            e
            for t, e in self.early_events
            if e.task_id == handle.task_id
            and e.server == handle.server
            and now - t < ORPHAN_GRACE_S
            and not handle.predates(e)  # a previous instance's, e.g. a reused watcher id
        ]
        for event in sorted(early, key=lambda e: e.seq):
            await self.on_task_event(event)

    async def on_task_event(self, event: TaskEvent) -> bool:
        """Reactions first, then step/UI updates and the planner inbox. False = orphan."""
        handle = self.registry.get(event.task_id)
        run = self.current_run()
        if handle is not None and handle.server != event.server:
            logger.warning(
                "agent_event_rejected", reason="task_of_another_server", task_id=event.task_id
            )
            return False
        if handle is not None and handle.predates(event):
            logger.info(
                "agent_event_stale_instance",
                task_id=event.task_id,
                server=event.server,
                type=event.type,
                event_ts=event.ts,
            )
            return False
        if handle is None and event.task_id in self.interrupted:
            logger.info(
                "agent_event_interrupted_mission",
                task_id=event.task_id,
                server=event.server,
                type=event.type,
            )
            return False
        if handle is None or run is None or handle.mission_id != run.mission.id:
            logger.info(
                "agent_event_orphan", task_id=event.task_id, server=event.server, type=event.type
            )
            self.early_events.append((time.monotonic(), event))
            if handle is None:
                self.links.stop_orphan_if_latched(event)
            return False
        lost = lost_link(event.payload) if event.type == "task_failed" else None
        if lost is not None and self.recovery.recovers(run, handle):
            self.registry.resolve(event)
            self.spawn(self.recovery.recover(run, handle, event, lost))
            return True
        return await self.deliver(run, handle, event)

    async def deliver(self, run: MissionRun, handle: TaskHandle, event: TaskEvent) -> bool:
        """Reactions, the step, the mission's log and the planner's inbox for ``event``."""
        for reaction in run.reactions.take(event):
            await self._react(run, reaction, event)
        self.registry.resolve(event)
        if event.type in TERMINAL_EVENTS:
            self.recovery.issued.pop(event.task_id, None)  # ended: nothing left to re-issue
        text = format_event(event, handle.label)
        self.trace.record(
            run.mission.id,
            "task_event",
            type=event.type,
            task_id=event.task_id,
            text=text,
            payload=event.payload,
        )
        step = run.mission.step(handle.step_id)
        if step is not None:
            if event.type == "progress":
                step.detail = progress_detail(event.payload)
            elif event.type == "task_done":
                step.set_status("succeeded", "done")
            elif event.type == "task_failed":
                code = event.payload.get("error_code", "FAILED")
                step.set_status("failed", f"{code}: {event.payload.get('message', '')}")
            await self.output.emit_plan(run)
        if text is not None:
            await self.output.log_line(run, "task_event", text)
            run.post(text)
        return True

    async def _react(self, run: MissionRun, reaction: Reaction, event: TaskEvent) -> None:
        call = reaction.call
        trigger = event.payload.get("trigger")
        name = (
            trigger.get("type", event.type)
            if isinstance(trigger, dict)
            else (trigger or event.type)
        )
        note = f"[reaction] {name} fired → called {call.tool}({_short(call.arguments)})"
        self.spawn(self._fire(run.mission.id, call.tool, call.arguments))
        run.inbox.append(note)
        await self.output.log_line(run, "reaction", note)
        self.trace.record(run.mission.id, "reaction", text=note)

    async def _fire(self, mission_id: str, tool: str, arguments: dict[str, Any]) -> None:
        # a prepared reaction never waits for a person: a confirm tool is refused, not asked
        with dispatching(DispatchContext(mission_id, may_ask=False)):
            outcome = await self.tools.call_tool(tool, arguments, self.config.tool_timeout_s)
        self.skills.note(tool, arguments, outcome.text, outcome.is_error)
        self.trace.record(
            mission_id,
            "tool_result",
            tool=tool,
            arguments=arguments,
            result=outcome.text[:500],
            is_error=outcome.is_error,
            reaction=True,
        )
        logger.info("reaction_dispatched", tool=tool, is_error=outcome.is_error)
        run = self.current_run()
        if outcome.is_error and run is not None and run.mission.id == mission_id:
            # the planner must not believe a reaction did what it failed to do
            line = f"[reaction] {tool} failed: {outcome.text[:300]}"
            run.post(line)
            await self.output.log_line(run, "reaction", line)

    async def cancel_task(self, server: str, task_id: str) -> None:
        outcome = await self.tools.call_tool(
            f"{server}.cancel_task", {"task_id": task_id}, self.config.tool_timeout_s
        )
        logger.info(
            "task_cancel_requested", server=server, task_id=task_id, is_error=outcome.is_error
        )

    async def end_task(self, handle: TaskHandle) -> None:
        """Retire a live task: cancel it on the server that owns it and, for a watcher,
        stop its skill on the server that started it (no watcher outlives its mission)."""
        self.registry.drop(handle.task_id)
        await self.cancel_task(handle.server, handle.task_id)
        if handle.skill_id is not None and handle.skill_server is not None:
            await self.stop_skill(ActiveSkill(handle.skill_server, handle.skill_id))

    async def stop_skill(self, skill: ActiveSkill) -> None:
        outcome = await self.tools.call_tool(
            skill.stop_tool, {"skill_id": skill.skill_id}, self.config.tool_timeout_s
        )
        self.skills.forget(skill.server, skill.skill_id)
        logger.info(
            "skill_stop_requested",
            server=skill.server,
            skill_id=skill.skill_id,
            is_error=outcome.is_error,
        )

    def still_running(self, run: MissionRun) -> bool:
        return (
            self.current_run() is run
            and run.mission.state == "running"
            and not run.awaiting_user
            and not self.latched()
        )

    def is_motion(self, server: str) -> bool:
        cfg = self.tools.servers().get(server)
        return cfg is not None and cfg.motion
