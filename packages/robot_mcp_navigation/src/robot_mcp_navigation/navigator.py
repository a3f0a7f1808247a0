"""Navigator: the application service behind the MCP tools.

Policy (documented in the README):
- One navigation at a time. A second ``navigate_to`` while one is running is **refused**
  with NAVIGATION_BUSY (naming the running task); the caller stops or cancels first. A
  physical robot should never change course because a request was repeated.
- A task exists only once the base took the goal (``MotionBase.start_drive``): a base that
  cannot (Nav2 absent, goal rejected) makes ``navigate_to`` a BASE_UNAVAILABLE error, and
  nothing moved. The slot is held meanwhile, so a parallel call is NAVIGATION_BUSY.
- Every task ends with exactly one terminal event: ``task_done``, or ``task_failed`` with a
  TaskFailure payload. A cancelled task (``cancel_task`` / ``stop_navigation``) ends in
  state ``cancelled`` and posts ``task_failed`` with error_code CANCELLED, recoverable
  true, so the brain resolves its step (spec 002 §5.4/§9). No progress or trigger event of
  a task is emitted after its cancellation was requested.
- Progress is emitted on the first report, then when the percentage grew by
  ``progress_pct_step`` or ``progress_interval_s`` robot-seconds passed. Triggers fire once.
- All durations (ETA, est_duration_s, elapsed) are robot-time seconds; with the simulated
  base that is simulated time (wall time × NAV_TIME_SCALE).
- Supervision (issue 27): with a ``Supervision``, ``navigate_to`` is refused while it refuses
  motion (SAFETY_STOP_LATCHED, NOT_SUPERVISED) — checked before the goal is sent and again
  once the base took it (a stop that came meanwhile cancels it at once). The composition
  root's watchdog calls :meth:`Navigator.stop` when the lease lapses or latches.
"""

from __future__ import annotations

import asyncio
import time
import uuid
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from functools import partial
from typing import Any

import structlog

from robot_mcp_kit.models import TaskFailure, TaskInfo, TaskState
from robot_mcp_kit.motion_tasks import MotionTask, MotionTasks, MotionWords, OnMotionTasks
from robot_mcp_kit.supervision import Supervision
from robot_mcp_kit.task_events import EventSink
from robot_mcp_kit.tasks import TaskTable
from robot_mcp_navigation.errors import (
    BaseUnavailableNavigationError,
    MotionRefusedError,
    NavigationBusyError,
    UnknownLocationError,
)
from robot_mcp_navigation.map import NavMap
from robot_mcp_navigation.motion.base import (
    BaseUnavailableError,
    DriveFailure,
    DriveGoal,
    DriveProgress,
    DriveResult,
    MotionBase,
)
from robot_mcp_navigation.triggers import Trigger

logger = structlog.get_logger(__name__)

TOOL = "navigate_to"


@dataclass(frozen=True)
class NavigatorSettings:
    time_scale: float = 1.0
    progress_interval_s: float = 2.0
    progress_pct_step: float = 10.0
    stop_timeout_s: float = 5.0
    drive_timeout_factor: float = 3.0
    drive_timeout_margin_s: float = 30.0


def new_task_id() -> str:
    return f"nav-{uuid.uuid4().hex[:8]}"


@dataclass(kw_only=True)
class _Drive(MotionTask):
    goal: DriveGoal
    triggers: list[Trigger]
    est_duration_s: float
    fired: set[int] = field(default_factory=set)
    last_pct: float | None = None
    last_progress_at: float = 0.0


def _busy(active: _Drive) -> NavigationBusyError:
    return NavigationBusyError(
        f"already navigating to {active.goal.name!r} (task {active.task_id}); "
        "call stop_navigation or cancel_task first"
    )


WORDS = MotionWords[_Drive](
    log="navigation",
    busy=_busy,
    refused=MotionRefusedError,
)


class Navigator(OnMotionTasks[_Drive]):
    def __init__(
        self,
        nav_map: NavMap,
        base: MotionBase,
        events: EventSink,
        tasks: TaskTable,
        settings: NavigatorSettings | None = None,
        task_ids: Callable[[], str] = new_task_id,
        supervision: Supervision | None = None,
    ) -> None:
        self._map = nav_map
        self._base = base
        self._settings = settings or NavigatorSettings()
        self._task_ids = task_ids
        self.supervision = supervision
        self.motion = MotionTasks[_Drive](
            events,
            tasks,
            WORDS,
            self._halt,
            gate=supervision,
            settle_timeout_s=self._settings.stop_timeout_s,
        )

    # -- queries -------------------------------------------------------------------------

    def locations(self) -> dict[str, Any]:
        here = self._base.current_pose()
        return {
            "map": self._map.name,
            "frame": self._map.frame,
            "speed_mps": self._map.speed_mps,
            "locations": [
                {
                    "name": name,
                    "description": loc.description,
                    "aliases": list(loc.aliases),
                    "x": loc.x,
                    "y": loc.y,
                    "distance_m": round(here.distance_to(loc.pose()), 2),
                    "est_duration_s": round(self._base.estimate_duration_s(loc.pose()), 1),
                }
                for name, loc in self._map.locations.items()
            ],
        }

    def pose(self) -> dict[str, Any]:
        pose = self._base.current_pose()
        at = next(
            (
                name
                for name, loc in self._map.locations.items()
                if pose.distance_to(loc.pose()) <= self._base.at_location_tolerance_m
            ),
            None,
        )
        active = self.motion.active
        status = self._base.pose_status()
        return {
            **pose.as_dict(),
            "frame": self._map.frame,
            "at_location": at,
            "moving": active is not None and not status.stale,  # a stale pose shows no motion
            "task_id": active.task_id if active else None,
            "destination": active.goal.name if active else None,
            **status.as_dict(),
        }

    def drive_started_at(self) -> float | None:
        """When the running drive began (``time.monotonic()``), None when not driving."""
        active = self.motion.active
        return active.started if active is not None else None

    # -- commands ------------------------------------------------------------------------

    def refuse_unsupervised(self) -> None:
        """Raise MotionRefusedError while supervision refuses motion (latched, unsupervised)."""
        self.motion.refuse_if_stopped()

    async def navigate_to(self, location: str, triggers: Iterable[Trigger] = ()) -> TaskInfo:
        self.refuse_unsupervised()
        name = self._map.resolve(location)
        if name is None:
            known = ", ".join(sorted(self._map.locations))
            raise UnknownLocationError(f"unknown location {location!r}; known: {known}")
        goal = DriveGoal(name, self._map.locations[name].pose())
        est = round(self._base.estimate_duration_s(goal.pose), 2)
        trigger_list = list(triggers)
        drive = _Drive(
            task_id=self._task_ids(),
            tool=TOOL,
            goal=goal,
            triggers=trigger_list,
            est_duration_s=est,
        )
        self.motion.claim(drive)  # held while the base takes the goal: a parallel call is BUSY
        started = time.monotonic()
        try:
            outcome = await self._base.start_drive(goal, partial(self._on_progress, drive))
        except BaseUnavailableError as exc:
            self.motion.release(drive)
            logger.warning("navigation_refused", destination=name, detail=exc.detail)
            raise BaseUnavailableNavigationError(exc.detail) from exc
        except BaseException:
            self.motion.release(drive)
            raise
        info = self.motion.register(
            drive, est, destination=name, triggers=[t.model_dump() for t in trigger_list]
        )
        self.motion.run(drive, self._run(drive, outcome))
        refused = self.motion.refusal()
        if refused is not None:  # latched or lapsed while the base took the goal
            await self.stop(reason=refused.detail)
            raise MotionRefusedError(refused.code, refused.detail)
        logger.info(
            "navigation_started",
            task_id=info.task_id,
            destination=name,
            est_s=est,
            duration_ms=round((time.monotonic() - started) * 1000, 1),
        )
        return info

    async def stop(self, reason: str = "stop_navigation") -> TaskInfo | None:
        """Halt at once; cancel the running navigation (if any) and return its final state."""
        return await self.motion.stop(reason)

    # -- the drive -------------------------------------------------------------------------

    async def _halt(self, active: _Drive | None) -> None:
        await self._base.stop()

    def _drive_timeout_s(self, drive: _Drive) -> float:
        s = self._settings
        robot_s = drive.est_duration_s * s.drive_timeout_factor + s.drive_timeout_margin_s
        return robot_s / s.time_scale

    async def _run(self, drive: _Drive, outcome: asyncio.Future[DriveResult]) -> TaskInfo:
        started = time.monotonic()
        result: DriveResult | None = None
        failure: DriveFailure | None = None
        try:
            async with asyncio.timeout(self._drive_timeout_s(drive)):
                result = await outcome
        except TimeoutError:
            await self._base.stop()
            failure = DriveFailure(
                "NAVIGATION_TIMEOUT",
                f"the drive to {drive.goal.name} took far longer than expected and was halted",
                recoverable=True,
                suggestions=["check for obstacles, then call navigate_to again"],
            )
        except Exception:  # the base is an adapter boundary: a crash must end the task cleanly
            logger.exception("drive_crashed", task_id=drive.task_id)
            await self._base.stop()
            failure = DriveFailure(
                "BASE_ERROR", "the robot base reported an internal error", recoverable=False
            )
        final = await self._finish(drive, result, failure)
        logger.info(
            "navigation_finished",
            task_id=drive.task_id,
            state=final.state,
            duration_ms=round((time.monotonic() - started) * 1000, 1),
        )
        return final

    async def _finish(
        self, drive: _Drive, result: DriveResult | None, failure: DriveFailure | None
    ) -> TaskInfo:
        pose = self._base.current_pose().as_dict()
        common = {"destination": drive.goal.name, "pose": pose}
        # the lock stopped the base before the watchdog's cancel (robot-sim aborts its goal the
        # moment its lock engages): the drive ended because supervision ended
        self.motion.blame_supervision(drive, ended=result is not None)
        if result is not None and result.status == "arrived":
            return await self.motion.succeed(
                drive, {**common, "duration_s": round(result.elapsed_s, 2)}
            )
        state: TaskState = "failed"
        ours = (
            result is not None
            and result.status == "failed"
            and drive.cancel_reason is not None
            and (result.failure is None or result.failure.error_code != "BASE_UNAVAILABLE")
        )
        if result is not None and result.status == "failed" and not ours:
            failure = result.failure
        elif result is not None and result.status in ("stopped", "failed"):
            # stopped, or a drive we asked to stop that the base ended its own way (robot-sim
            # aborts the goal when its supervisor lock engages, as Nav2's progress checker would)
            if drive.cancel_reason is not None:
                state = "cancelled"
                failure = DriveFailure(
                    "CANCELLED",
                    f"navigation to {drive.goal.name} was cancelled ({drive.cancel_reason}); "
                    "the robot halted where it is",
                    recoverable=True,
                    suggestions=[f'call navigate_to("{drive.goal.name}") to resume the drive'],
                )
            else:
                failure = DriveFailure(
                    "BASE_STOPPED",
                    "the robot base halted on its own (e.g. an emergency stop)",
                    recoverable=True,
                    suggestions=["check the robot is safe to move, then call navigate_to again"],
                )
        assert failure is not None
        task_failure = TaskFailure(
            error_code=failure.error_code,
            message=failure.message,
            recoverable=failure.recoverable,
            suggestions=list(failure.suggestions),
        )
        return await self.motion.fail(drive, state, task_failure, common)

    async def _on_progress(self, drive: _Drive, progress: DriveProgress) -> None:
        if drive.cancel_reason is not None:
            return
        pct = round(progress.fraction * 100, 1)
        snapshot = {
            "destination": drive.goal.name,
            "pct": pct,
            "eta_s": round(progress.eta_s, 2),
            "distance_remaining_m": round(progress.distance_remaining_m, 2),
            "elapsed_s": round(progress.elapsed_s, 2),
            "pose": progress.pose.as_dict(),
        }
        drive.latest = snapshot
        for index, trigger in enumerate(drive.triggers):
            if index not in drive.fired and trigger.is_met(progress):
                drive.fired.add(index)
                await self.motion.emit_live(
                    drive, "trigger_fired", {**snapshot, "trigger": trigger.model_dump()}
                )
        s = self._settings
        if (
            drive.last_pct is None
            or pct - drive.last_pct >= s.progress_pct_step
            or progress.elapsed_s - drive.last_progress_at >= s.progress_interval_s
        ):
            drive.last_pct = pct
            drive.last_progress_at = progress.elapsed_s
            await self.motion.emit_live(drive, "progress", snapshot)
