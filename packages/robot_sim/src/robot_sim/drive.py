"""The simulated drive, time-scaled. Pure: the caller passes the clock reading, so tests step
time by hand.

With a :class:`RobotMap` (the world robot-sim runs), a goal is planned on the robot's costmap
and followed waypoint by waypoint at the map's speed; every ``SENSE_STEP_M`` of the way the
robot looks around, and when what it knows changed (a door it sees closed) it replans from
where it is. No path → the drive fails the way Nav2's planner does (``NO_VALID_PATH`` 208),
where the robot stands. Without one (unit tests of the motion alone), the path is the straight
line and the map's ``failures:`` entries (the scripted closed door) still apply.
"""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass, field
from itertools import pairwise
from typing import Literal

from robot_sim.costmap import RobotMap
from robot_sim.planner import NO_VALID_PATH, NoPathError, Point, path_length
from robot_site_map import FailureSpec, NavMap, Pose

GOAL_MATCH_M = 0.25
"""A goal this close to a map location counts as a drive to that location (for failures)."""
SENSE_STEP_M = 0.25
"""How far the robot moves between two looks at its surroundings."""


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
    plan: tuple[Point, ...] = ()
    """The path still ahead, from the robot's position to the goal (empty when not driving)."""
    replans: int = 0
    error_code: int = 0
    """Nav2's code for a failed drive (208 NO_VALID_PATH, ...)."""
    error_msg: str = ""

    @property
    def driving(self) -> bool:
        return self.status == "driving"


@dataclass
class _Route:
    goal: Pose
    started: float
    path: list[Point]
    updated: float
    """The clock reading the position along ``path`` is for."""
    along: float = 0.0
    """Metres driven along ``path`` (replanning starts a new path)."""
    failure: FailureSpec | None = None
    total: float = 0.0
    """Length of the scripted failure's straight line (failure at a fraction of it)."""
    replans: int = 0
    pose: Pose | None = None
    lengths: list[float] = field(default_factory=list)


class DriveSim:
    """One robot on ``nav_map``; ``time_scale`` robot seconds per wall second."""

    def __init__(
        self,
        nav_map: NavMap,
        time_scale: float = 1.0,
        failures: bool = True,
        robot_map: RobotMap | None = None,
    ) -> None:
        if time_scale <= 0:
            raise ValueError("time_scale must be positive")
        self.map = nav_map
        self.speed = nav_map.speed_mps
        self.time_scale = time_scale
        self.robot_map = robot_map
        self._failures = list(nav_map.failures) if failures else []
        self._lock = threading.Lock()
        self._pose = nav_map.locations[nav_map.start].pose()
        self._route: _Route | None = None
        self._last = DriveState(self._pose, "idle", 0.0, 0.0, 0.0)
        if robot_map is not None:
            robot_map.sense(self._pose)

    def location_at(self, pose: Pose) -> str | None:
        for name, location in self.map.locations.items():
            if location.pose().distance_to(pose) <= GOAL_MATCH_M:
                return name
        return None

    def start(self, goal: Pose, now: float) -> DriveState:
        """Drive to ``goal`` from where the robot is now (a running drive is replaced)."""
        with self._lock:
            pose = self._advance(now).pose
            self._pose, self._route = pose, None
            origin = (pose.x, pose.y)
            failure = self._take_failure(goal)
            if self.robot_map is None or failure is not None:
                path = [origin, (goal.x, goal.y)]
            else:
                self.robot_map.sense(pose)
                try:
                    path = self.robot_map.plan(origin, (goal.x, goal.y))
                except NoPathError as error:
                    self._last = DriveState(
                        pose,
                        "failed",
                        0.0,
                        0.0,
                        0.0,
                        error_code=error.code,
                        error_msg=error.message,
                    )
                    return self._last
            route = _Route(goal, now, path, now, failure=failure, pose=pose)
            route.total = path_length(path)
            self._route = route
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
        step = max(0.0, now - route.updated) * self.time_scale * self.speed
        route.updated = max(route.updated, now)
        elapsed = max(0.0, now - route.started) * self.time_scale
        while True:
            length = path_length(route.path)
            if (
                route.failure is not None
                and route.along + step >= route.total * route.failure.at_fraction
            ):
                route.along = route.total * route.failure.at_fraction
                pose = _at(route.path, route.along, route.goal)
                failure = route.failure
                remaining = length - route.along
                return self._end(
                    DriveState(
                        pose, "failed", remaining, elapsed, 0.0, failure,
                        error_code=NO_VALID_PATH, error_msg=failure.message,
                    )
                )  # fmt: skip
            move = min(step, SENSE_STEP_M, length - route.along)
            route.along += move
            step -= move
            pose = _at(route.path, route.along, route.goal)
            if route.along >= length - 1e-9:
                return self._end(
                    DriveState(route.goal, "arrived", 0.0, elapsed, 0.0, replans=route.replans)
                )
            if self.robot_map is not None and route.failure is None and self.robot_map.sense(pose):
                try:
                    route.path = self.robot_map.plan((pose.x, pose.y), (route.goal.x, route.goal.y))
                except NoPathError as error:
                    return self._end(
                        DriveState(
                            pose, "failed", length - route.along, elapsed, 0.0,
                            replans=route.replans, error_code=error.code, error_msg=error.message,
                        )
                    )  # fmt: skip
                route.along, route.replans = 0.0, route.replans + 1
                continue
            if step <= 0.0:
                break
        remaining = path_length(route.path) - route.along
        ahead = _ahead(route.path, route.along)
        self._last = DriveState(
            pose,
            "driving",
            remaining,
            elapsed,
            remaining / self.speed,
            speed_mps=self.speed,
            plan=tuple(ahead),
            replans=route.replans,
        )
        return self._last

    def _end(self, state: DriveState) -> DriveState:
        self._pose, self._route, self._last = state.pose, None, state
        return state


def _at(path: list[Point], along: float, goal: Pose) -> Pose:
    """The pose ``along`` metres down ``path``, heading along its segment."""
    walked = 0.0
    for (x0, y0), (x1, y1) in pairwise(path):
        segment = math.hypot(x1 - x0, y1 - y0)
        if segment <= 0.0:
            continue
        if walked + segment >= along:
            f = (along - walked) / segment
            return Pose(x0 + (x1 - x0) * f, y0 + (y1 - y0) * f, math.atan2(y1 - y0, x1 - x0))
        walked += segment
    return goal


def _ahead(path: list[Point], along: float) -> list[Point]:
    """The rest of ``path`` from ``along`` metres down it."""
    walked = 0.0
    for i, ((x0, y0), (x1, y1)) in enumerate(pairwise(path)):
        segment = math.hypot(x1 - x0, y1 - y0)
        if walked + segment >= along:
            f = (along - walked) / segment if segment > 0 else 0.0
            return [(x0 + (x1 - x0) * f, y0 + (y1 - y0) * f), *path[i + 1 :]]
        walked += segment
    return path[-1:]
