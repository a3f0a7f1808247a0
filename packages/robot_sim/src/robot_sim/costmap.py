"""What the robot knows of its world, as Nav2's global costmap does: the static layer is
map_server's map (doors drawn open), the obstacle layer adds what the robot's sensor saw.

A door is observed when its centre is within ``sensor_range_m`` of the robot and nothing of
the static map stands on the line between them (Nav2's obstacle layer marks and clears by
raytracing from the sensor). An observed door's state replaces what the robot believed; a door
out of sight keeps its last observed state. So a robot that never came near the closed
mailroom door plans through it, sees it closed when it gets there, and replans.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Callable

import numpy as np
from skimage.draw import line

from robot_sim.floor.floor import Floor
from robot_sim.floor.grid import Grid
from robot_sim.planner import Costmap, GridPlanner, Point
from robot_site_map import Pose

SENSOR_RANGE_M = 3.5


class RobotMap:
    def __init__(
        self,
        floor: Floor,
        closed_doors: Callable[[], frozenset[str]],
        planner: GridPlanner | None = None,
        sensor_range_m: float = SENSOR_RANGE_M,
    ) -> None:
        self.floor = floor
        self.planner = planner or GridPlanner()
        self.sensor_range_m = sensor_range_m
        self._closed_doors = closed_doors
        self._lock = threading.Lock()
        self._known_closed: frozenset[str] = frozenset()
        self._costmap = self.planner.costmap(floor.grid)
        self.version = 0
        """Grows whenever what the robot knows changes (the costmap to publish)."""

    @property
    def known_closed(self) -> frozenset[str]:
        return self._known_closed

    def grid(self) -> Grid:
        """The robot's global costmap: the map plus the doors it saw closed."""
        return self._costmap.grid

    def sense(self, pose: Pose) -> bool:
        """Observe the doors in sight from ``pose``; True when what the robot knows changed."""
        truth = self._closed_doors()
        with self._lock:
            known = set(self._known_closed)
            for name, door in self.floor.plan.doors.items():
                if self._sees(pose, name, door.centre):
                    known.discard(name)
                    if name in truth:
                        known.add(name)
            if known == self._known_closed:
                return False
            self._known_closed = frozenset(known)
            self._costmap = self.planner.costmap(self.floor.with_doors_closed(known))
            self.version += 1
            return True

    def plan(self, start: Point, goal: Point) -> list[Point]:
        with self._lock:
            costmap = self._costmap
        return self.planner.plan(costmap, start, goal)

    def costmap(self) -> Costmap:
        with self._lock:
            return self._costmap

    def _sees(self, pose: Pose, door: str, centre: Point) -> bool:
        if math.hypot(centre[0] - pose.x, centre[1] - pose.y) > self.sensor_range_m:
            return False
        grid = self.floor.grid
        r0, c0 = grid.cell_of(pose.x, pose.y)
        r1, c1 = grid.cell_of(*centre)
        rows, cols = line(r0, c0, r1, c1)  # type: ignore[no-untyped-call]
        inside = (rows >= 0) & (rows < grid.height) & (cols >= 0) & (cols < grid.width)
        rows, cols = rows[inside], cols[inside]
        own = self.floor.door_cells[door][rows, cols]
        return not bool(np.any(grid.occupied[rows, cols] & ~own))
