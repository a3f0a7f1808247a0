"""The simulated drive: straight-line motion at the map's speed, time-scaled, with the
map's ``failures:`` (the robot stops in front of the closed door). Pure: the caller passes
the clock reading, so tests step time by hand.
"""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass
from typing import Literal

from robot_mcp_navigation.map import FailureSpec, NavMap
from robot_mcp_navigation.motion.base import Pose

GOAL_MATCH_M = 0.25
"""A goal this close to a map location counts as a drive to that location (for failures)."""


@dataclass(frozen=True)
class DriveState:
    pose: Pose
    status: Literal["idle", "driving", "arrived", "failed", "halted"]
    distance_remaining_m: float
    elapsed_s: float
    """Robot seconds since the drive began."""
    eta_s: float
    failure: FailureSpec | None = None
    speed_mps: float = 0.0

    @property
    def driving(self) -> bool:
        return self.status == "driving"


@dataclass
class _Route:
    origin: Pose
    goal: Pose
    started: float
    failure: FailureSpec | None


class DriveSim:
    """One robot on ``nav_map``; ``time_scale`` robot seconds per wall second."""

    def __init__(self, nav_map: NavMap, time_scale: float = 1.0, failures: bool = True) -> None:
        if time_scale <= 0:
            raise ValueError("time_scale must be positive")
        self.map = nav_map
        self.speed = nav_map.speed_mps
        self.time_scale = time_scale
        self._failures = list(nav_map.failures) if failures else []
        self._lock = threading.Lock()
        self._pose = nav_map.locations[nav_map.start].pose()
        self._route: _Route | None = None
        self._last = DriveState(self._pose, "idle", 0.0, 0.0, 0.0)

    def location_at(self, pose: Pose) -> str | None:
        for name, location in self.map.locations.items():
            if location.pose().distance_to(pose) <= GOAL_MATCH_M:
                return name
        return None

    def start(self, goal: Pose, now: float) -> DriveState:
        """Drive to ``goal`` from where the robot is now (a running drive is replaced)."""
        with self._lock:
            pose = self._advance(now).pose
            self._pose = pose
            self._route = _Route(pose, goal, now, self._take_failure(goal))
            return self._advance(now)

    def halt(self, now: float) -> DriveState:
        """Stop where the robot is (idempotent)."""
        with self._lock:
            state = self._advance(now)
            if self._route is not None:
                self._pose, self._route = state.pose, None
                state = DriveState(
                    state.pose, "halted", state.distance_remaining_m, state.elapsed_s, 0.0
                )
                self._last = state
            return state

    def state(self, now: float) -> DriveState:
        with self._lock:
            return self._advance(now)

    def estimate_s(self, goal: Pose, now: float) -> float:
        return self.state(now).pose.distance_to(goal) / self.speed

    def _take_failure(self, goal: Pose) -> FailureSpec | None:
        place = self.location_at(goal)
        for failure in self._failures:
            if failure.location == place:
                if failure.mode == "once":
                    self._failures.remove(failure)
                return failure
        return None

    def _advance(self, now: float) -> DriveState:
        route = self._route
        if route is None:
            return self._last
        elapsed = max(0.0, now - route.started) * self.time_scale
        total = route.origin.distance_to(route.goal)
        fraction = 1.0 if total <= 0 else min(1.0, elapsed * self.speed / total)
        failure = route.failure
        if failure is not None and fraction >= failure.at_fraction:
            pose = _interpolate(route.origin, route.goal, failure.at_fraction)
            remaining = total * (1.0 - failure.at_fraction)
            self._end(DriveState(pose, "failed", remaining, elapsed, 0.0, failure))
        elif fraction >= 1.0:
            self._end(DriveState(route.goal, "arrived", 0.0, elapsed, 0.0))
        else:
            pose = _interpolate(route.origin, route.goal, fraction)
            remaining = total * (1.0 - fraction)
            self._last = DriveState(
                pose, "driving", remaining, elapsed, remaining / self.speed, speed_mps=self.speed
            )
        return self._last

    def _end(self, state: DriveState) -> None:
        self._pose, self._route, self._last = state.pose, None, state


def _interpolate(origin: Pose, goal: Pose, fraction: float) -> Pose:
    if fraction >= 1.0:
        return goal
    heading = math.atan2(goal.y - origin.y, goal.x - origin.x) if origin != goal else goal.theta
    return Pose(
        origin.x + (goal.x - origin.x) * fraction,
        origin.y + (goal.y - origin.y) * fraction,
        heading,
    )
