"""MotionGoal: one goal the robot's action server accepted, as a motion server's port names it
(navigation's ``Nav2Goal``, the arm's ``ArmGoal``); ``O`` is the domain's outcome. No ROS types
cross it: the rclpy adapter wraps ``robot_ros_bridge.action_goal.ActionGoal``, tests a fake."""

from __future__ import annotations

import abc
from typing import Generic, Literal, TypeVar

GoalStatus = Literal["succeeded", "aborted", "canceled", "unknown"]
O = TypeVar("O")  # noqa: E741 - the outcome type


class MotionGoal(abc.ABC, Generic[O]):
    @abc.abstractmethod
    async def outcome(self) -> O:
        """Wait for the server's terminal status (no deadline: the caller sets one)."""

    @abc.abstractmethod
    async def cancel(self, timeout_s: float) -> bool:
        """Ask the server to cancel; True when it accepted the request within ``timeout_s``.
        The goal is canceled once :meth:`outcome` reports ``canceled``."""
