"""ArmActions: the port between the manipulator service and ROS (the Pick and Place action
clients of ``robot_manipulation_interfaces`` and the latched held-object topic). The rclpy
adapter is ``rclpy_arm.py``; tests use ``fake.py``. No rclpy types cross the port.
"""

from __future__ import annotations

import abc
from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal

from robot_mcp_kit.motion_errors import UnavailableError
from robot_mcp_kit.motion_goal import GoalStatus, MotionGoal

PlaceMode = Literal["place", "release"]


@dataclass(frozen=True)
class DetectionTarget:
    """A pick goal's reference to a detection on the data plane (the brain's ``mask_ref``)."""

    topic: str
    stamp_s: float
    index: int = -1
    label: str = ""


@dataclass(frozen=True)
class Held:
    """What the gripper holds, as the robot reports it."""

    holding: bool
    label: str = ""
    since_s: float = 0.0

    def as_dict(self) -> dict[str, object]:
        return {
            "holding": self.holding,
            "label": self.label or None,
            "since": round(self.since_s, 3) if self.holding and self.since_s else None,
        }


@dataclass(frozen=True)
class ArmFeedback:
    phase: str
    progress: float


@dataclass(frozen=True)
class ArmOutcome:
    """How the action server ended a goal; ``error_code`` is the action's Result constant."""

    status: GoalStatus
    error_code: int = 0
    error_msg: str = ""
    held: Held | None = None
    placed_label: str = ""


class ArmUnavailableError(UnavailableError):
    """No action server answered, or it rejected the goal: the goal is not running."""


class ArmGoal(MotionGoal[ArmOutcome]):
    """One Pick or Place goal the action server accepted."""


FeedbackCallback = Callable[[ArmFeedback], None]


class ArmActions(abc.ABC):
    """The robot's Pick and Place action servers and its held-object topic."""

    @abc.abstractmethod
    async def send_pick(
        self,
        target: DetectionTarget,
        max_age_s: float,
        on_feedback: FeedbackCallback,
        timeout_s: float,
    ) -> ArmGoal:
        """Send a pick goal; return once the server accepted it. Raises ArmUnavailableError
        when no server is ready within ``timeout_s`` or it rejects the goal."""

    @abc.abstractmethod
    async def send_place(
        self, mode: PlaceMode, on_feedback: FeedbackCallback, timeout_s: float
    ) -> ArmGoal:
        """Send a place (or release) goal; as :meth:`send_pick`."""

    @abc.abstractmethod
    def held(self) -> Held | None:
        """The last held-object message (None before the first)."""

    def close(self) -> None:  # noqa: B027 - optional hook
        """Release the ROS side (idempotent)."""
