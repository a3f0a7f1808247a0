"""Step 1 of the recipe: the dock's port (what the service needs of the robot) and its fake.
A real server adds ``rclpy_dock.py`` here: ``ActionGoals`` over its Dock action."""

from __future__ import annotations

import asyncio
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Literal

Status = Literal["succeeded", "aborted", "canceled", "unknown"]


class DockUnavailable(RuntimeError):
    """No dock answered, or it refused the goal: nothing moved."""


@dataclass
class FakeDockGoal:
    """One docking goal; the test ends it (``finish``) or a cancel does."""

    on_feedback: Callable[[float], None]
    ended: asyncio.Future[Status] = field(
        default_factory=lambda: asyncio.get_running_loop().create_future()
    )
    cancel_requests: int = 0

    async def outcome(self) -> Status:
        return await self.ended

    async def cancel(self, timeout_s: float) -> bool:
        self.cancel_requests += 1
        self.finish("canceled")
        return True

    def finish(self, status: Status) -> None:
        if not self.ended.done():
            self.ended.set_result(status)


@dataclass
class FakeDock:
    """The robot's docking action: ``refuse`` makes the next goal unavailable."""

    goals: list[FakeDockGoal] = field(default_factory=list)
    refuse: bool = False

    async def send(self, on_feedback: Callable[[float], None]) -> FakeDockGoal:
        if self.refuse:
            raise DockUnavailable("no dock action server on /dock")
        goal = FakeDockGoal(on_feedback)
        self.goals.append(goal)
        return goal
