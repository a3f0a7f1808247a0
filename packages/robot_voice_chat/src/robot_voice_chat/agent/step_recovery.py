"""Motion steps that lost a link for a moment, recovered within their mission (agent.lapse).

The dispatcher records each motion call as it sent it; when its task ends because supervision
lapsed or the base went silent for a moment — the brain alive, the stop not latched, the mission
running — the call is re-issued under the same step (at most ``MAX_RECOVERIES`` times), and the
person is told once. The re-issued task carries the old one's label, and calls naming the old
task id reach the new one. A motion call refused ``NOT_SUPERVISED`` as it was sent is sent again
once the lock is open (:meth:`StepRecovery.resend_refused`).
"""

from __future__ import annotations

import asyncio
import time
from collections.abc import Callable
from typing import Any, Protocol

import structlog

from robot_mcp_kit.models import TaskEvent
from robot_voice_chat.agent.lapse import (
    BASE_BACK_WAIT_S,
    MAX_RECOVERIES,
    RECOVER_WAIT_S,
    IssuedCall,
    LostLink,
    base_answers,
    carrying_on,
    refused_unsupervised,
)
from robot_voice_chat.agent.output import MissionOutput
from robot_voice_chat.agent.run import MissionRun
from robot_voice_chat.agent.task_registry import TaskHandle, parse_task_info
from robot_voice_chat.agent.trace import TraceRecorder
from robot_voice_chat.control.context import DispatchContext, dispatching
from robot_voice_chat.control.supervisor import MotionSupervisor
from robot_voice_chat.services.tools.base import ToolBackend, ToolOutcome
from robot_voice_chat.settings import AgentConfig

logger = structlog.get_logger(__name__)
RESEND_PAUSE_S = 0.25
RESEND_CHECK_S = 0.5  # a refused call waiting for the lock looks at the latch this often


class RecoveryHost(Protocol):
    """What recovery uses of the dispatcher."""

    tools: ToolBackend
    trace: TraceRecorder
    config: AgentConfig
    output: MissionOutput
    supervisor: MotionSupervisor | None
    motion_steps_in_flight: set[str]
    latched: Callable[[], bool]

    async def deliver(self, run: MissionRun, handle: TaskHandle, event: TaskEvent) -> bool: ...

    async def register_task(
        self,
        run: MissionRun,
        dotted: str,
        step_id: str | None,
        info: dict[str, Any],
        sent_at: float,
        shown_as: str | None = None,
    ) -> None: ...

    def still_running(self, run: MissionRun) -> bool: ...

    def is_motion(self, server: str) -> bool: ...


class StepRecovery:
    """Each motion call as sent, the task a re-issued one replaced (old id → new), and how
    often each step was re-issued (at most ``MAX_RECOVERIES``)."""

    def __init__(self, host: RecoveryHost) -> None:
        self._host = host
        self.issued: dict[str, IssuedCall] = {}
        self.aliases: dict[str, str] = {}
        self.recovered: dict[tuple[str, str | None], int] = {}

    def current_task_id(self, task_id: str) -> str:
        """The task that carries on ``task_id`` after lapses (itself if none re-issued it)."""
        seen = {task_id}
        while task_id in self.aliases and self.aliases[task_id] not in seen:
            task_id = self.aliases[task_id]
            seen.add(task_id)
        return task_id

    def recovers(self, run: MissionRun, handle: TaskHandle) -> bool:
        """A motion step of the running mission that ended because a link was lost for a moment
        (supervision lapsed, the base went silent), with the brain alive, the stop not latched,
        the mission not paused and the step re-issued fewer than ``MAX_RECOVERIES`` times:
        recovered here instead of failing (agent.lapse)."""
        issued = self.issued.get(handle.task_id)
        return (
            self._host.supervisor is not None
            and self._host.is_motion(handle.server)
            and issued is not None
            and not self._host.latched()
            and run.mission.state == "running"
            and not run.awaiting_user
            and self.recovered.get((run.mission.id, issued.step_id), 0) < MAX_RECOVERIES
        )

    async def recover(
        self, run: MissionRun, handle: TaskHandle, event: TaskEvent, lost: LostLink
    ) -> None:
        """Re-lease, wait for the server's lock to open (and a lost base's fresh pose), re-issue
        the step's call and say so (the first time only); if any of that fails, the planner gets
        the failure as it came."""
        assert self._host.supervisor is not None
        issued = self.issued.pop(handle.task_id)
        mission = run.mission
        key = (mission.id, issued.step_id)
        self.recovered[key] = times = self.recovered.get(key, 0) + 1
        logger.warning(
            "supervision_lapse_recovering",
            server=handle.server,
            task_id=handle.task_id,
            step_id=issued.step_id,
            lost=lost,
            times=times,
        )
        step = mission.step(issued.step_id)
        if step is not None:
            link = "safety link" if lost == "lease" else "contact with the base"
            step.detail = f"{link} lost for a moment: resuming"
            await self._host.output.emit_plan(run)
        deadline = time.monotonic() + RECOVER_WAIT_S
        opened = lost == "lease" or await self._base_back(handle.server)
        left = max(0.0, deadline - time.monotonic())
        opened = opened and await self._host.supervisor.wait_lock_open(handle.server, left)
        if not (opened and self._host.still_running(run)):
            logger.warning(
                "supervision_lapse_not_recovered",
                server=handle.server,
                task_id=handle.task_id,
                lock_open=opened,
            )
            if self._host.still_running(run):
                await self._host.deliver(run, handle, event)
            return
        sent_at = time.time()
        # refused unsupervised: nothing moved, the lease lapsed again (the host is still
        # catching up): sent again once the lock is open, within the same wait
        outcome = await self.resend_refused(
            run, issued, await self._send_again(run, issued), deadline
        )
        info = None if outcome.is_error else parse_task_info(outcome.text)
        self._host.trace.record(
            mission.id,
            "lapse_recovered" if info is not None else "lapse_not_recovered",
            tool=issued.tool,
            arguments=issued.arguments,
            step_id=issued.step_id,
            replaces=handle.task_id,
            result=outcome.text[:500],
            is_error=outcome.is_error,
        )
        if info is None:
            logger.warning(
                "supervision_lapse_not_recovered", server=handle.server, result=outcome.text[:200]
            )
            if self._host.still_running(run):  # a stop meanwhile owns the step: nothing to add
                await self._host.deliver(run, handle, event)
            return
        new_id = str(info["task_id"])
        self.issued[new_id] = issued
        self.aliases[handle.task_id] = new_id
        logger.info("supervision_lapse_recovered", replaces=handle.task_id, task_id=new_id)
        await self._host.register_task(
            run, issued.tool, issued.step_id, info, sent_at, shown_as=handle.label
        )
        if self._host.still_running(run) and times == 1:
            await self._host.output.say(run, carrying_on(issued, lost))

    async def resend_refused(
        self,
        run: MissionRun,
        issued: IssuedCall,
        outcome: ToolOutcome,
        deadline: float | None = None,
    ) -> ToolOutcome:
        """A motion call refused ``NOT_SUPERVISED`` as it was sent (the lease lapsed a moment
        before, the brain alive, nothing moved): sent again once the server's lock is open,
        until ``deadline`` (monotonic; ``RECOVER_WAIT_S`` from now); otherwise the refusal."""
        supervisor = self._host.supervisor
        server = issued.tool.partition(".")[0]
        deadline = deadline or time.monotonic() + RECOVER_WAIT_S
        while (  # still running: not latched, not paused, not waiting on the person
            supervisor is not None
            and refused_unsupervised(outcome)
            and self._host.still_running(run)
        ):
            left = deadline - time.monotonic()
            if left <= 0:
                break
            if not await supervisor.wait_lock_open(server, min(left, RESEND_CHECK_S)):
                continue  # the latch, a stop or the deadline is looked at again first
            logger.info("supervision_lapse_resend", server=server, step_id=issued.step_id)
            outcome = await self._send_again(run, issued)
            if refused_unsupervised(outcome):
                await asyncio.sleep(RESEND_PAUSE_S)  # a lock that reads open but refuses
        return outcome

    async def _send_again(self, run: MissionRun, issued: IssuedCall) -> ToolOutcome:
        if issued.step_id is not None:
            self._host.motion_steps_in_flight.add(issued.step_id)
        try:
            with dispatching(DispatchContext(run.mission.id, issued.step_id)):
                return await self._host.tools.call_tool(
                    issued.tool, issued.arguments, self._host.config.tool_timeout_s
                )
        finally:
            if issued.step_id is not None:
                self._host.motion_steps_in_flight.discard(issued.step_id)

    async def _base_back(self, server: str) -> bool:
        """The base shows a fresh pose again within ``BASE_BACK_WAIT_S`` (``get_pose``)."""
        deadline = time.monotonic() + BASE_BACK_WAIT_S
        while True:
            outcome = await self._host.tools.call_tool(f"{server}.get_pose", {}, BASE_BACK_WAIT_S)
            if not outcome.is_error and base_answers(outcome.text):
                return True
            if time.monotonic() >= deadline:
                logger.warning("base_not_back", server=server, wait_s=BASE_BACK_WAIT_S)
                return False
            await asyncio.sleep(0.25)
