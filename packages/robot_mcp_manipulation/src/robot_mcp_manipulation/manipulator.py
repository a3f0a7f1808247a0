"""Manipulator: the application service behind the MCP tools (mirrors navigation's Navigator).

Policy (documented in the README):
- One motion at a time: a pick or place while another runs is **refused** with
  MANIPULATION_BUSY (naming the running task). A repeated request must never change what
  the arm does silently; the caller stops or cancels first.
- Motion is admitted at one seam (``robot_mcp_kit.motion_tasks.MotionGate``): before the goal
  is sent and again once the arm took it (a refusal that came meanwhile cancels the goal at once).
- A task exists only once the arm's action server accepted the goal: an absent or refusing
  server is ARM_UNAVAILABLE, and nothing moved.
- Every task ends with exactly one terminal event: ``task_done`` (with what is held, read from
  the robot), or ``task_failed`` with a TaskFailure. A cancelled task (``cancel_task``,
  ``stop_manipulation``, shutdown) ends ``cancelled`` with CANCELLED, recoverable; no progress
  event of a task follows its cancellation.
"""

from __future__ import annotations

import asyncio
import time
import uuid
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Literal

import structlog

from robot_mcp_kit.models import TaskFailure, TaskInfo, TaskState
from robot_mcp_kit.motion_tasks import (
    MotionGate,
    MotionTask,
    MotionTasks,
    MotionWords,
    OnMotionTasks,
)
from robot_mcp_kit.task_events import EventSink
from robot_mcp_kit.tasks import TaskTable
from robot_mcp_manipulation.arm.error_codes import Action, named_failure
from robot_mcp_manipulation.arm.port import (
    ArmActions,
    ArmFeedback,
    ArmGoal,
    ArmOutcome,
    ArmUnavailableError,
    DetectionTarget,
    PlaceMode,
)
from robot_mcp_manipulation.errors import (
    ArmUnavailableManipulationError,
    ManipulationBusyError,
    ManipulationError,
)

logger = structlog.get_logger(__name__)

Tool = Literal["pick", "place", "release"]


@dataclass(frozen=True)
class ManipulatorSettings:
    server_timeout_s: float = 5.0
    cancel_timeout_s: float = 5.0
    task_timeout_s: float = 60.0
    pick_est_s: float = 8.0
    place_est_s: float = 6.0


def new_task_id() -> str:
    return f"manip-{uuid.uuid4().hex[:8]}"


@dataclass(kw_only=True)
class _Motion(MotionTask):
    tool: Tool
    label: str
    goal: ArmGoal | None = None


def _busy(active: _Motion) -> ManipulationBusyError:
    return ManipulationBusyError(
        f"the arm is busy with {active.tool} (task {active.task_id}); "
        "call stop_manipulation or cancel_task first"
    )


def _refused(code: str, detail: str) -> ManipulationError:
    return ManipulationError(detail, code=code)


WORDS = MotionWords[_Motion](log="manipulation", busy=_busy, refused=_refused)


class Manipulator(OnMotionTasks[_Motion]):
    def __init__(
        self,
        arm: ArmActions,
        events: EventSink,
        tasks: TaskTable,
        settings: ManipulatorSettings | None = None,
        gate: MotionGate | None = None,
        task_ids: Callable[[], str] = new_task_id,
    ) -> None:
        self._arm = arm
        self._settings = settings or ManipulatorSettings()
        self._task_ids = task_ids
        self.motion = MotionTasks[_Motion](
            events,
            tasks,
            WORDS,
            self._halt,
            gate=gate,
            settle_timeout_s=self._settings.cancel_timeout_s,
        )
        self.gate = self.motion.gate

    # -- queries ---------------------------------------------------------------------------

    def held(self) -> dict[str, Any]:
        """What the gripper holds, as the robot last reported it (``known`` false before)."""
        held = self._arm.held()
        active = self.motion.active
        state: dict[str, Any] = (
            {"known": False, "holding": None, "label": None, "since": None}
            if held is None
            else {"known": True, **held.as_dict()}
        )
        return {
            **state,
            "busy": active is not None,
            "task_id": active.task_id if active else None,
            "action": active.tool if active else None,
        }

    # -- commands --------------------------------------------------------------------------

    async def pick(self, target: DetectionTarget, max_age_s: float = 0.0) -> TaskInfo:
        motion = self._claim("pick", target.label)
        s = self._settings
        return await self._start(
            motion,
            lambda fb: self._arm.send_pick(target, max_age_s, fb, s.server_timeout_s),
            s.pick_est_s,
            detection={"topic": target.topic, "stamp": target.stamp_s, "index": target.index},
        )

    async def place(self, mode: PlaceMode = "place") -> TaskInfo:
        held = self._arm.held()
        motion = self._claim(mode, held.label if held is not None else "")
        s = self._settings
        return await self._start(
            motion, lambda fb: self._arm.send_place(mode, fb, s.server_timeout_s), s.place_est_s
        )

    async def stop(self, reason: str = "stop_manipulation") -> TaskInfo | None:
        """Cancel the running pick/place (if any) and return its final state."""
        return await self.motion.stop(reason)

    # -- the motion --------------------------------------------------------------------------

    def _claim(self, tool: Tool, label: str) -> _Motion:
        self.motion.refuse_if_stopped(tool=tool)
        # held while the arm takes the goal: a parallel call is BUSY
        return self.motion.claim(_Motion(task_id=self._task_ids(), tool=tool, label=label))

    async def _start(
        self,
        motion: _Motion,
        send: Callable[[Callable[[ArmFeedback], None]], Any],
        est_s: float,
        **extra: Any,
    ) -> TaskInfo:
        try:
            goal: ArmGoal = await send(lambda fb: self._on_feedback(motion, fb))
        except ArmUnavailableError as exc:
            self.motion.release(motion)
            logger.warning("manipulation_unavailable", tool=motion.tool, detail=exc.detail)
            raise ArmUnavailableManipulationError(exc.detail) from exc
        except BaseException:
            self.motion.release(motion)
            raise
        motion.goal = goal
        info = self.motion.register(motion, est_s, label=motion.label or None, **extra)
        refused = self.motion.refusal()
        if refused is not None and motion.cancel_reason is None:
            motion.cancel_reason = refused.code  # a stop came while the goal was being taken
        if motion.cancel_reason is not None:
            await self._cancel(goal)
        self.motion.run(motion, self._run(motion, goal))
        logger.info(
            "manipulation_started",
            task_id=motion.task_id,
            tool=motion.tool,
            label=motion.label,
            duration_ms=round((time.monotonic() - motion.started) * 1000, 1),
        )
        return info

    async def _halt(self, active: _Motion | None) -> None:
        if active is not None and active.goal is not None:
            await self._cancel(active.goal)

    async def _cancel(self, goal: ArmGoal) -> None:
        if not await goal.cancel(self._settings.cancel_timeout_s):
            logger.warning("arm_cancel_refused")

    async def _run(self, motion: _Motion, goal: ArmGoal) -> TaskInfo:
        outcome: ArmOutcome
        try:
            async with asyncio.timeout(self._settings.task_timeout_s):
                outcome = await goal.outcome()
        except TimeoutError:
            await self._cancel(goal)
            outcome = ArmOutcome("aborted", -1, "timeout")
        except Exception as exc:  # the ROS side is a boundary: a lost result ends the task
            logger.exception("arm_result_failed", task_id=motion.task_id)
            outcome = ArmOutcome("unknown", error_msg=str(exc) or type(exc).__name__)
        return await self._finish(motion, outcome)

    async def _finish(self, motion: _Motion, outcome: ArmOutcome) -> TaskInfo:
        await self.motion.flush_live(motion)  # progress before the terminal event, in order
        held = outcome.held or self._arm.held()
        common = {
            "action": motion.tool,
            "label": motion.label or None,
            "held": held.as_dict() if held is not None else None,
        }
        duration = round(time.monotonic() - motion.started, 2)
        if outcome.status == "succeeded":
            done = {**common, "duration_s": duration}
            if motion.tool != "pick":
                done["placed_label"] = outcome.placed_label or motion.label or None
            info = await self.motion.succeed(motion, done)
            logger.info("manipulation_finished", task_id=motion.task_id, state="succeeded")
            return info
        # the stop's cancel-all reached the arm before the watchdog's own cancel: the pick
        # ended because supervision ended, not "on its own"
        self.motion.blame_supervision(
            motion, ended=outcome.status == "canceled", reason=lambda refused: refused.code
        )
        state: TaskState = "failed"
        failure = self._failure(motion, outcome)
        if outcome.status == "canceled" and motion.cancel_reason is not None:
            state = "cancelled"
        info = await self.motion.fail(motion, state, failure, common)
        logger.info(
            "manipulation_finished",
            task_id=motion.task_id,
            state=state,
            error_code=failure.error_code,
            duration_ms=round(duration * 1000, 1),
        )
        return info

    def _failure(self, motion: _Motion, outcome: ArmOutcome) -> TaskFailure:
        what: Action = "pick" if motion.tool == "pick" else "place"
        thing = f" the {motion.label}" if motion.label else ""
        if outcome.status == "canceled":
            if motion.cancel_reason is not None:
                return TaskFailure(
                    error_code="CANCELLED",
                    message=f"the {motion.tool} of{thing or ' it'} was cancelled "
                    f"({motion.cancel_reason}); the arm stopped",
                    recoverable=True,
                    suggestions=["call get_held to see what the robot holds, then try again"],
                )
            return TaskFailure(
                error_code="ARM_STOPPED",
                message="the arm stopped on its own (e.g. an emergency stop)",
                recoverable=True,
                suggestions=["check the robot is safe to move, then call get_held and retry"],
            )
        if outcome.status == "aborted" and outcome.error_code == -1:
            return TaskFailure(
                error_code="MANIPULATION_TIMEOUT",
                message=f"the {motion.tool} took far longer than expected and was cancelled",
                recoverable=True,
                suggestions=["call get_held to see what the robot holds, then try again once"],
            )
        if outcome.status == "aborted":
            named = named_failure(what, outcome.error_code)
            said = outcome.error_msg.strip() or "no message"
            return TaskFailure(
                error_code=named.code,
                message=f"{named.what} ({said})",
                recoverable=named.recoverable,
                suggestions=list(named.suggestions),
            )
        return TaskFailure(
            error_code="ARM_ERROR",
            message=f"lost track of the {motion.tool} goal ({outcome.error_msg or 'no result'})",
            recoverable=False,
            suggestions=["call get_held, then ask an operator whether the arm is moving"],
        )

    def _on_feedback(self, motion: _Motion, feedback: ArmFeedback) -> None:
        if motion.cancel_reason is not None:
            return
        snapshot = {
            "action": motion.tool,
            "label": motion.label or None,
            "phase": feedback.phase,
            "pct": round(max(0.0, min(1.0, feedback.progress)) * 100, 1),
        }
        if motion.latest is not None and motion.latest["phase"] == feedback.phase:
            return
        motion.latest = snapshot
        self.motion.emit_live_soon(motion, "progress", snapshot)
