"""Nav2Action: the port between Nav2MotionBase and ROS (a NavigateToPose action client and the
pose topic). The rclpy adapter lives in ``rclpy_action.py``; tests use ``fake.py``.

Everything here is plain Python on the asyncio side: no rclpy types cross the port.
"""

from __future__ import annotations

import abc
from collections.abc import Callable
from dataclasses import dataclass

from robot_mcp_kit.motion_errors import UnavailableError
from robot_mcp_kit.motion_goal import GoalStatus, MotionGoal
from robot_mcp_navigation.motion.base import Pose
from robot_mcp_navigation.motion.nav2.pose_watch import Relocation


@dataclass(frozen=True)
class Nav2Feedback:
    """NavigateToPose feedback in plain units (seconds, metres)."""

    pose: Pose
    distance_remaining_m: float
    eta_s: float
    navigation_time_s: float
    recoveries: int


@dataclass(frozen=True)
class Nav2Outcome:
    """How the action server ended a goal; ``error_code``/``error_msg`` as Nav2 set them."""

    status: GoalStatus
    error_code: int = 0
    error_msg: str = ""


@dataclass(frozen=True)
class PoseSample:
    """A pose from the pose topic and when it arrived (``time.monotonic()``)."""

    pose: Pose
    received_at: float


class Nav2UnavailableError(UnavailableError):
    """No action server answered, or it rejected the goal: the goal is not running."""


class Nav2Goal(MotionGoal[Nav2Outcome]):
    """One NavigateToPose goal the action server accepted."""


class Nav2Action(abc.ABC):
    """A NavigateToPose action client plus the robot's pose topic."""

    @abc.abstractmethod
    async def send_goal(
        self,
        pose: Pose,
        frame: str,
        on_feedback: Callable[[Nav2Feedback], None],
        timeout_s: float,
    ) -> Nav2Goal:
        """Send a goal; return once the server accepted it.

        ``on_feedback`` is called on the event loop for every feedback message. Raises
        Nav2UnavailableError when no server is ready within ``timeout_s``, the server does
        not answer in time, or it rejects the goal.
        """

    @abc.abstractmethod
    def latest_pose(self) -> PoseSample | None:
        """The last pose from the pose topic (``None`` before the first message)."""

    async def cancel_all(self, timeout_s: float) -> int | None:
        """Ask the action server to cancel every goal it runs (the action protocol's
        cancel-all: a zero goal id and stamp); how many it cancels, None if no server answered
        within ``timeout_s``."""
        return 0

    def last_relocation(self) -> Relocation | None:
        """The latest time the pose topic came back somewhere else after a silence
        (``pose_watch.PoseContinuity``); None if it never did."""
        return None

    def close(self) -> None:  # noqa: B027 - optional hook, nothing to release by default
        """Release the ROS side (idempotent)."""
