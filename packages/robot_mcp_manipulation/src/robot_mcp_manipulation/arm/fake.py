"""FakeArm: the ArmActions port in memory, failing the way the rclpy adapter does.

- no server (``available = False``): a goal waits out its timeout, then ArmUnavailableError;
- ``reject_next``: the server rejects the goal (ArmUnavailableError);
- a goal the server already ended ignores a cancel (``cancel`` returns False), like rclpy.
The test plays the server: ``feedback``, ``succeed``, ``abort``, ``cancel_by_server``.
"""

from __future__ import annotations

import asyncio
from dataclasses import dataclass, field

from robot_mcp_manipulation.arm.port import (
    ArmActions,
    ArmFeedback,
    ArmGoal,
    ArmOutcome,
    ArmUnavailableError,
    DetectionTarget,
    FeedbackCallback,
    Held,
    PlaceMode,
)


@dataclass
class FakeArmGoal(ArmGoal):
    kind: str
    on_feedback: FeedbackCallback
    target: DetectionTarget | None = None
    mode: PlaceMode | None = None
    max_age_s: float = 0.0
    cancel_requests: int = 0
    _outcome: asyncio.Future[ArmOutcome] = field(
        default_factory=lambda: asyncio.get_running_loop().create_future()
    )

    @property
    def done(self) -> bool:
        return self._outcome.done()

    async def outcome(self) -> ArmOutcome:
        return await asyncio.shield(self._outcome)

    async def cancel(self, timeout_s: float) -> bool:
        self.cancel_requests += 1
        if self._outcome.done():
            return False
        self._outcome.set_result(ArmOutcome("canceled"))
        return True

    # -- the test plays the action server --------------------------------------------------
    def feedback(self, phase: str, progress: float) -> None:
        self.on_feedback(ArmFeedback(phase, progress))

    def succeed(self, held: Held | None = None, placed_label: str = "") -> None:
        self._outcome.set_result(ArmOutcome("succeeded", held=held, placed_label=placed_label))

    def canceled_by_another_client(self) -> None:
        """The action server ended the goal for a cancel this server did not send (a stop's
        cancel-all of every goal below it)."""
        self._outcome.set_result(ArmOutcome("canceled"))

    def abort(self, error_code: int, error_msg: str = "", held: Held | None = None) -> None:
        self._outcome.set_result(ArmOutcome("aborted", error_code, error_msg, held))

    def lose(self, error: Exception) -> None:
        self._outcome.set_exception(error)


class FakeArm(ArmActions):
    def __init__(self, *, available: bool = True) -> None:
        self.available = available
        self.reject_next = False
        self.goals: list[FakeArmGoal] = []
        self.goal_sent = asyncio.Event()
        self._held: Held | None = None
        self.closed = False

    async def _accept(self, goal: FakeArmGoal, timeout_s: float) -> FakeArmGoal:
        if not self.available:
            await asyncio.sleep(timeout_s)
            raise ArmUnavailableError(f"no {goal.kind} action server within {timeout_s} s")
        if self.reject_next:
            self.reject_next = False
            raise ArmUnavailableError(f"the {goal.kind} action server rejected the goal")
        self.goals.append(goal)
        self.goal_sent.set()
        return goal

    async def send_pick(
        self,
        target: DetectionTarget,
        max_age_s: float,
        on_feedback: FeedbackCallback,
        timeout_s: float,
    ) -> ArmGoal:
        goal = FakeArmGoal("pick", on_feedback, target=target, max_age_s=max_age_s)
        return await self._accept(goal, timeout_s)

    async def send_place(
        self, mode: PlaceMode, on_feedback: FeedbackCallback, timeout_s: float
    ) -> ArmGoal:
        return await self._accept(FakeArmGoal("place", on_feedback, mode=mode), timeout_s)

    def publish_held(self, held: Held) -> None:
        """A message on the held-object topic."""
        self._held = held

    def held(self) -> Held | None:
        return self._held

    def close(self) -> None:
        self.closed = True
