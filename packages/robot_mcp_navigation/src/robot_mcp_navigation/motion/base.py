"""MotionBase: the port between the navigation service and whatever moves the robot.

Adapters: ``SimulatedBase`` (an in-process dot on the map, for tests) and ``Nav2MotionBase``
(a Nav2 ``NavigateToPose`` action client); ``composition.py`` picks one (``NAV_MOTION``).
All durations here are robot-time seconds (simulated seconds for the simulated base).
"""

from __future__ import annotations

import abc
import asyncio
from collections.abc import Awaitable, Callable
from dataclasses import dataclass, field
from typing import Any, Literal

from robot_mcp_kit.motion_errors import UnavailableError
from robot_site_map import Pose as Pose  # the pose type, shared with robot-sim


@dataclass(frozen=True)
class DriveGoal:
    name: str
    pose: Pose


@dataclass(frozen=True)
class DriveProgress:
    pose: Pose
    distance_total_m: float
    distance_remaining_m: float
    eta_s: float
    elapsed_s: float

    @property
    def fraction(self) -> float:
        if self.distance_total_m <= 0:
            return 1.0
        return max(0.0, min(1.0, 1.0 - self.distance_remaining_m / self.distance_total_m))


@dataclass(frozen=True)
class DriveFailure:
    error_code: str
    message: str
    recoverable: bool = False
    suggestions: list[str] = field(default_factory=list)


@dataclass(frozen=True)
class DriveResult:
    status: Literal["arrived", "failed", "stopped"]
    pose: Pose
    elapsed_s: float
    failure: DriveFailure | None = None


@dataclass(frozen=True)
class PoseStatus:
    """How much to trust ``current_pose`` (get_pose reports it beside the pose).

    ``stale``: no pose from the base now (never one, or none since the base stopped
    answering, or older than the configured age); ``note`` says why in words. ``relocated``:
    the base's pose came back after a silence far from where it was last seen (a restarted
    base), ``{"from": {x, y}, "to": {x, y}, "distance_m", "ago_s"}``, so a display never
    moves the robot without saying so.
    """

    stale: bool = False
    age_s: float | None = None
    note: str | None = None
    relocated: dict[str, Any] | None = None

    def as_dict(self) -> dict[str, Any]:
        return {
            "stale": self.stale,
            "pose_age_s": None if self.age_s is None else round(self.age_s, 2),
            "pose_note": self.note,
            "relocated": self.relocated,
        }


ProgressCallback = Callable[[DriveProgress], Awaitable[None]]


class MotionBusyError(RuntimeError):
    """drive_to was called while the base is already driving."""


class BaseUnavailableError(UnavailableError):
    """The base cannot take a goal now (its driver is absent or rejected the goal); nothing
    moved. ``detail`` says why, for the planner and the operator."""


class MotionBase(abc.ABC):
    """Drives the robot to a pose, reports progress, and halts on request."""

    at_location_tolerance_m: float = 0.05
    """How close the pose must be to a location to count as being there."""

    @abc.abstractmethod
    async def drive_to(self, goal: DriveGoal, on_progress: ProgressCallback) -> DriveResult:
        """Drive to ``goal``; await ``on_progress`` while moving; return how it ended.

        Returns ``stopped`` when :meth:`stop` halted the drive. Raises MotionBusyError if a
        drive is already under way.
        """

    async def start_drive(
        self, goal: DriveGoal, on_progress: ProgressCallback
    ) -> asyncio.Future[DriveResult]:
        """Start driving to ``goal``; return once the base has taken the goal, with the
        drive's outcome still to come.

        Raises BaseUnavailableError when the base cannot take the goal (nothing moved).
        The default suits a base that takes every goal at once (it just runs ``drive_to``);
        a base with a driver that may be absent or refuse overrides it.
        """
        return asyncio.ensure_future(self.drive_to(goal, on_progress))

    @abc.abstractmethod
    async def stop(self) -> None:
        """Halt at once (idempotent; also fine when not moving)."""

    @abc.abstractmethod
    def current_pose(self) -> Pose:
        """Where the robot is now."""

    @abc.abstractmethod
    def estimate_duration_s(self, goal: Pose) -> float:
        """Expected robot-time seconds from the current pose to ``goal``."""

    def pose_status(self) -> PoseStatus:
        """Whether ``current_pose`` is live; a base that always knows its pose keeps this."""
        return PoseStatus()

    async def cancel_stale_goals(self) -> None:  # noqa: B027 - optional hook
        """At start-up, before any lease opens the lock: end goals an earlier life of this
        server left running at the base (a base with nothing left over keeps the default)."""
