"""FakeNav2Action: the Nav2Action port in memory, failing the way the rclpy adapter does.

- no server (``available = False``): ``send_goal`` waits out its timeout, then raises
  Nav2UnavailableError — as the real client does while Nav2 is not up;
- ``reject_next``: the server answers and rejects the goal (Nav2UnavailableError);
- a goal the server already ended ignores a cancel (``cancel`` returns False), like rclpy;
- ``cancel_answers = False``: the server never answers a cancel request (a hung Nav2).
- ``vanish()``: the server process is gone (kill -9): no more feedback, no result, cancels
  unanswered, new goals time out.
The test plays the server: ``feedback``, ``succeed``, ``abort``, ``cancel_by_server``.
"""

from __future__ import annotations

import asyncio
import time
from collections.abc import Callable
from dataclasses import dataclass, field

from robot_mcp_navigation.motion.base import Pose
from robot_mcp_navigation.motion.nav2.port import (
    Nav2Action,
    Nav2Feedback,
    Nav2Goal,
    Nav2Outcome,
    Nav2UnavailableError,
    PoseSample,
)
from robot_mcp_navigation.motion.nav2.pose_watch import PoseContinuity, Relocation


@dataclass
class FakeGoal(Nav2Goal):
    pose: Pose
    frame: str
    on_feedback: Callable[[Nav2Feedback], None]
    cancel_answers: bool = True
    cancel_requests: int = 0
    _outcome: asyncio.Future[Nav2Outcome] = field(
        default_factory=lambda: asyncio.get_running_loop().create_future()
    )

    @property
    def done(self) -> bool:
        return self._outcome.done()

    async def outcome(self) -> Nav2Outcome:
        return await asyncio.shield(self._outcome)

    async def cancel(self, timeout_s: float) -> bool:
        self.cancel_requests += 1
        if not self.cancel_answers:
            await asyncio.sleep(timeout_s)  # the request goes unanswered until the deadline
            return False
        if self._outcome.done():
            return False
        self._outcome.set_result(Nav2Outcome("canceled"))
        return True

    # -- the test plays the action server --------------------------------------------------

    def feedback(
        self,
        pose: Pose,
        distance_remaining_m: float,
        eta_s: float = 0.0,
        navigation_time_s: float = 0.0,
        recoveries: int = 0,
    ) -> None:
        self.on_feedback(
            Nav2Feedback(pose, distance_remaining_m, eta_s, navigation_time_s, recoveries)
        )

    def succeed(self) -> None:
        self._outcome.set_result(Nav2Outcome("succeeded"))

    def abort(self, error_code: int, error_msg: str = "") -> None:
        self._outcome.set_result(Nav2Outcome("aborted", error_code, error_msg))

    def cancel_by_server(self) -> None:
        self._outcome.set_result(Nav2Outcome("canceled"))

    def lose(self, error: Exception) -> None:
        self._outcome.set_exception(error)


class FakeNav2Action(Nav2Action):
    def __init__(self, *, available: bool = True) -> None:
        self.available = available
        self.reject_next = False
        self.cancel_answers = True
        self.accept_delay_s = 0.0  # how long the server takes to answer a goal
        self.goals: list[FakeGoal] = []
        self.closed = False
        self._pose: PoseSample | None = None
        self._continuity = PoseContinuity()
        self.goal_sent = asyncio.Event()
        self.cancel_all_calls = 0

    async def send_goal(
        self,
        pose: Pose,
        frame: str,
        on_feedback: Callable[[Nav2Feedback], None],
        timeout_s: float,
    ) -> Nav2Goal:
        if not self.available:
            await asyncio.sleep(timeout_s)
            raise Nav2UnavailableError(f"no NavigateToPose server within {timeout_s} s")
        await asyncio.sleep(self.accept_delay_s)
        if self.reject_next:
            self.reject_next = False
            raise Nav2UnavailableError("the NavigateToPose server rejected the goal")
        goal = FakeGoal(pose, frame, on_feedback, cancel_answers=self.cancel_answers)
        self.goals.append(goal)
        self.goal_sent.set()
        return goal

    def publish_pose(self, pose: Pose, at: float | None = None) -> None:
        """A message on the pose topic (``at``: its arrival, ``time.monotonic()`` by default)."""
        self._pose = PoseSample(pose, time.monotonic() if at is None else at)
        self._continuity.observe(pose, self._pose.received_at)

    def latest_pose(self) -> PoseSample | None:
        return self._pose

    def last_relocation(self) -> Relocation | None:
        return self._continuity.relocation

    async def cancel_all(self, timeout_s: float) -> int | None:
        self.cancel_all_calls += 1
        if not self.available:
            return None
        running = [g for g in self.goals if not g.done]
        for goal in running:
            goal.cancel_by_server()
        return len(running)

    def vanish(self) -> None:
        """The action server's process died: it answers nothing any more."""
        self.available = False
        self.cancel_answers = False
        for goal in self.goals:
            goal.cancel_answers = False

    def close(self) -> None:
        self.closed = True
