"""SimulatedBase: straight-line motion at a constant speed, time-scaled, with map failures."""

from __future__ import annotations

import asyncio
import contextlib
import json
import math
import time
from collections.abc import Callable, Sequence
from pathlib import Path

import structlog

from robot_mcp_navigation.map import FailureSpec
from robot_mcp_navigation.motion.base import (
    DriveFailure,
    DriveGoal,
    DriveProgress,
    DriveResult,
    MotionBase,
    MotionBusyError,
    Pose,
    ProgressCallback,
)

logger = structlog.get_logger(__name__)


class PoseFile:
    """Where the simulated base keeps its pose across restarts, so a restarted server does not
    teleport the robot back to the dock (issue 23 item 7). JSON, replaced atomically; written
    at most every ``min_interval_s`` while driving and always when a drive ends or stops."""

    def __init__(
        self,
        path: Path,
        map_name: str,
        min_interval_s: float = 0.25,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.path = path
        self.map_name = map_name
        self._min_interval_s = min_interval_s
        self._clock = clock
        self._saved_at: float | None = None
        self._failed = False

    def load(self) -> Pose | None:
        """The saved pose on this map; None when there is none (or it is unreadable)."""
        try:
            data = json.loads(self.path.read_text())
            if data.get("map") != self.map_name:
                logger.warning("pose_file_other_map", path=str(self.path), map=data.get("map"))
                return None
            return Pose(float(data["x"]), float(data["y"]), float(data.get("theta", 0.0)))
        except FileNotFoundError:
            return None
        except (OSError, ValueError, TypeError, KeyError, AttributeError) as exc:
            logger.warning("pose_file_unreadable", path=str(self.path), error=str(exc))
            return None

    def save(self, pose: Pose, force: bool = False) -> None:
        now = self._clock()
        if not force and self._saved_at is not None and now - self._saved_at < self._min_interval_s:
            return
        self._saved_at = now
        body = json.dumps({"map": self.map_name, **pose.as_dict(), "ts": round(time.time(), 3)})
        tmp = self.path.with_name(f".{self.path.name}.tmp")
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            tmp.write_text(body)
            tmp.replace(self.path)
        except OSError as exc:
            if not self._failed:  # once: a drive never fails because its pose can't be kept
                logger.error("pose_file_write_failed", path=str(self.path), error=str(exc))
            self._failed = True


class SimulatedBase(MotionBase):
    """Moves a virtual robot along the straight line to the goal.

    ``time_scale`` simulated seconds pass per wall-clock second (20 → a 30 s drive takes
    1.5 s). A map failure for the goal's location halts the robot at ``at_fraction`` of the
    route and ends the drive as ``failed``; ``once`` failures are used up when they fire.
    With a :class:`PoseFile` the pose survives a restart (the saved one replaces ``start``).
    """

    def __init__(
        self,
        start: Pose,
        speed_mps: float,
        time_scale: float = 1.0,
        failures: Sequence[FailureSpec] = (),
        tick_s: float = 0.05,
        clock: Callable[[], float] = time.monotonic,
        pose_file: PoseFile | None = None,
    ) -> None:
        if speed_mps <= 0 or time_scale <= 0 or tick_s <= 0:
            raise ValueError("speed_mps, time_scale and tick_s must be positive")
        self._pose_file = pose_file
        restored = pose_file.load() if pose_file is not None else None
        if restored is not None:
            logger.info("pose_restored", pose=restored.as_dict())
        self._pose = restored or start
        self._speed = speed_mps
        self._time_scale = time_scale
        self._failures = list(failures)
        self._tick_s = tick_s
        self._clock = clock
        self._stop = asyncio.Event()
        self._driving = False
        self._stopped_after_s = 0.0
        self._route: tuple[Pose, DriveGoal, float] | None = None  # origin, goal, started_at

    @property
    def driving(self) -> bool:
        return self._driving

    def current_pose(self) -> Pose:
        if self._route is not None:
            return self._pose_now()[0]
        return self._pose

    def estimate_duration_s(self, goal: Pose) -> float:
        return self.current_pose().distance_to(goal) / self._speed

    async def stop(self) -> None:
        if self._route is not None:
            self._pose, _, self._stopped_after_s = self._pose_now()
            self._route = None
            self._keep(self._pose, force=True)
        self._stop.set()

    async def drive_to(self, goal: DriveGoal, on_progress: ProgressCallback) -> DriveResult:
        if self._driving:
            raise MotionBusyError("the simulated base is already driving")
        self._driving = True
        self._stop.clear()
        self._stopped_after_s = 0.0
        origin = self._pose
        total = origin.distance_to(goal.pose)
        failure = self._take_failure(goal.name)
        self._route = (origin, goal, self._clock())
        logger.info("drive_started", goal=goal.name, distance_m=round(total, 2))
        try:
            while True:
                if self._stop.is_set():
                    return DriveResult("stopped", self._pose, self._stopped_after_s)
                pose, fraction, elapsed = self._pose_now()
                if failure is not None and fraction >= failure.at_fraction:
                    return self._fail_at(origin, goal, failure, elapsed)
                if fraction >= 1.0:
                    # A final report at the goal, so triggers a coarse tick jumped over
                    # (high time scale) still fire before the drive ends.
                    await on_progress(DriveProgress(goal.pose, total, 0.0, 0.0, elapsed))
                    self._pose = goal.pose
                    self._route = None
                    self._keep(goal.pose, force=True)
                    return DriveResult("arrived", goal.pose, elapsed)
                self._keep(pose)
                remaining = max(0.0, total - fraction * total)
                await on_progress(
                    DriveProgress(pose, total, remaining, remaining / self._speed, elapsed)
                )
                with contextlib.suppress(TimeoutError):
                    async with asyncio.timeout(self._tick_s):
                        await self._stop.wait()
        finally:
            self._driving = False

    def _keep(self, pose: Pose, force: bool = False) -> None:
        if self._pose_file is not None:
            self._pose_file.save(pose, force)

    def _pose_now(self) -> tuple[Pose, float, float]:
        """Pose, fraction of the route done and simulated seconds since the drive began."""
        assert self._route is not None
        origin, goal, started = self._route
        elapsed = (self._clock() - started) * self._time_scale
        total = origin.distance_to(goal.pose)
        fraction = 1.0 if total <= 0 else min(1.0, elapsed * self._speed / total)
        return _interpolate(origin, goal.pose, fraction), fraction, elapsed

    def _fail_at(
        self, origin: Pose, goal: DriveGoal, failure: FailureSpec, elapsed: float
    ) -> DriveResult:
        self._pose = _interpolate(origin, goal.pose, failure.at_fraction)
        self._route = None
        self._keep(self._pose, force=True)
        logger.info("drive_failure_injected", goal=goal.name, error_code=failure.error_code)
        return DriveResult(
            "failed",
            self._pose,
            elapsed,
            DriveFailure(
                failure.error_code, failure.message, failure.recoverable, list(failure.suggestions)
            ),
        )

    def _take_failure(self, location: str) -> FailureSpec | None:
        for failure in self._failures:
            if failure.location == location:
                if failure.mode == "once":
                    self._failures.remove(failure)
                return failure
        return None


def _interpolate(origin: Pose, goal: Pose, fraction: float) -> Pose:
    if fraction >= 1.0:
        return goal
    heading = math.atan2(goal.y - origin.y, goal.x - origin.x) if origin != goal else goal.theta
    return Pose(
        origin.x + (goal.x - origin.x) * fraction,
        origin.y + (goal.y - origin.y) * fraction,
        heading,
    )
