"""Steps 2 and 3 of the recipe: the dock's errors and its service on ``MotionTasks`` — only
what docking means (the goal, its failures); the slot, the task table, the events, the gate,
stop and cancel are the kit's."""

from __future__ import annotations

import uuid
from dataclasses import dataclass

from robot_mcp_kit.models import TaskFailure, TaskInfo
from robot_mcp_kit.motion_errors import MotionError
from robot_mcp_kit.motion_tasks import (
    MotionGate,
    MotionTask,
    MotionTasks,
    MotionWords,
    OnMotionTasks,
)
from robot_mcp_kit.task_events import EventSink
from robot_mcp_kit.tasks import TaskTable

from .port import DockUnavailable, FakeDock, FakeDockGoal


class DockingError(MotionError):
    code = "DOCKING_ERROR"


class DockingBusyError(DockingError):
    code = "DOCKING_BUSY"


class DockUnavailableError(DockingError):
    code = "DOCK_UNAVAILABLE"


@dataclass(kw_only=True)
class Docking(MotionTask):
    goal: FakeDockGoal | None = None


WORDS = MotionWords[Docking](
    log="docking",
    busy=lambda active: DockingBusyError(f"already docking (task {active.task_id})"),
    refused=lambda code, detail: DockingError(detail, code),
)


class Docker(OnMotionTasks[Docking]):
    def __init__(
        self, dock: FakeDock, events: EventSink, tasks: TaskTable, gate: MotionGate | None = None
    ) -> None:
        self._dock = dock
        self.motion = MotionTasks[Docking](events, tasks, WORDS, self._halt, gate=gate)

    async def dock(self) -> TaskInfo:
        self.motion.refuse_if_stopped()
        docking = self.motion.claim(Docking(task_id=f"dock-{uuid.uuid4().hex[:8]}", tool="dock"))
        try:
            goal = await self._dock.send(lambda pct: self._on_feedback(docking, pct))
        except DockUnavailable as exc:
            self.motion.release(docking)
            raise DockUnavailableError(str(exc)) from exc
        docking.goal = goal
        info = self.motion.register(docking, 20.0)
        self.motion.run(docking, self._follow(docking, goal))
        return info

    async def stop(self, reason: str = "stop_docking") -> TaskInfo | None:
        return await self.motion.stop(reason)

    async def _halt(self, active: Docking | None) -> None:
        if active is not None and active.goal is not None:
            await active.goal.cancel(1.0)

    def _on_feedback(self, docking: Docking, pct: float) -> None:
        docking.latest = {"pct": pct}
        self.motion.emit_live_soon(docking, "progress", {"pct": pct})

    async def _follow(self, docking: Docking, goal: FakeDockGoal) -> TaskInfo:
        status = await goal.outcome()
        await self.motion.flush_live(docking)
        if status == "succeeded":
            return await self.motion.succeed(docking, {"docked": True})
        self.motion.blame_supervision(docking, ended=status == "canceled")
        if status == "canceled" and docking.cancel_reason is not None:
            failure = TaskFailure(
                error_code="CANCELLED",
                message=f"docking was cancelled ({docking.cancel_reason})",
                recoverable=True,
            )
            return await self.motion.fail(docking, "cancelled", failure, {"docked": False})
        failure = TaskFailure(error_code="DOCK_FAILED", message="the robot did not dock")
        return await self.motion.fail(docking, "failed", failure, {"docked": False})
