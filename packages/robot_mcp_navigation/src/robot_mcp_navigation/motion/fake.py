"""FakeMotionBase: a base the test drives by hand (progress, arrival, failure, stop)."""

from __future__ import annotations

import asyncio

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


class FakeMotionBase(MotionBase):
    """Records goals and stops; the test decides when and how each drive ends."""

    def __init__(self, start: Pose | None = None, speed_mps: float = 1.0) -> None:
        self.pose = start or Pose(0.0, 0.0)
        self.speed_mps = speed_mps
        self.goals: list[DriveGoal] = []
        self.stop_calls = 0
        self._outcome: asyncio.Future[DriveResult] | None = None
        self._on_progress: ProgressCallback | None = None
        self._total = 0.0

    @property
    def driving(self) -> bool:
        return self._outcome is not None and not self._outcome.done()

    def current_pose(self) -> Pose:
        return self.pose

    def estimate_duration_s(self, goal: Pose) -> float:
        return self.pose.distance_to(goal) / self.speed_mps

    async def drive_to(self, goal: DriveGoal, on_progress: ProgressCallback) -> DriveResult:
        if self.driving:
            raise MotionBusyError("fake base already driving")
        self.goals.append(goal)
        self._on_progress = on_progress
        self._total = self.pose.distance_to(goal.pose)
        self._outcome = asyncio.get_running_loop().create_future()
        return await self._outcome

    async def report(self, remaining_m: float, elapsed_s: float) -> None:
        """Report progress as the base would: ``remaining_m`` still to go."""
        assert self._on_progress is not None, "no drive under way"
        await self._on_progress(
            DriveProgress(
                self.pose, self._total, remaining_m, remaining_m / self.speed_mps, elapsed_s
            )
        )

    def arrive(self, elapsed_s: float = 1.0) -> None:
        goal = self.goals[-1].pose
        self.pose = goal
        self._finish(DriveResult("arrived", goal, elapsed_s))

    def fail(self, failure: DriveFailure, elapsed_s: float = 1.0) -> None:
        self._finish(DriveResult("failed", self.pose, elapsed_s, failure))

    async def stop(self) -> None:
        self.stop_calls += 1
        self._finish(DriveResult("stopped", self.pose, 0.0))

    def _finish(self, result: DriveResult) -> None:
        if self._outcome is not None and not self._outcome.done():
            self._outcome.set_result(result)
