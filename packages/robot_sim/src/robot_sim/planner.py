"""The global planner: a minimum-cost path on the occupancy grid (scikit-image's
``MCP_Geometric``, Dijkstra on the 8-connected grid), as Nav2's NavFn plans on its costmap.

The costmap is Nav2's idea: cells that are occupied or unknown are lethal, cells closer to one
than the robot's radius are lethal too (the inscribed radius), and up to ``inflation_radius``
the cost falls off exponentially, so paths keep to the middle of doors and corridors. The
cell path is thinned with scikit-image's Douglas–Peucker (``approximate_polygon``) to at most
``SIMPLIFY_CELLS`` off the planned cells, which stay far further than that from any wall.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from itertools import pairwise

import cv2
import numpy as np
import numpy.typing as npt
from skimage.graph import MCP_Geometric
from skimage.measure import approximate_polygon

from robot_sim.floor.grid import Grid

Point = tuple[float, float]
SIMPLIFY_CELLS = 1.5

NO_VALID_PATH = 208
"""``ComputePathToPose`` NO_VALID_PATH (Nav2 1.4, Kilted)."""
START_OCCUPIED = 205
GOAL_OCCUPIED = 206
OUTSIDE_MAP = 204


class NoPathError(RuntimeError):
    """No path: ``code`` is the ComputePathToPose error code Nav2's planner server gives."""

    def __init__(self, code: int, message: str) -> None:
        super().__init__(message)
        self.code = code
        self.message = message


@dataclass(frozen=True)
class Costmap:
    """Per-cell travel cost (inf = lethal), from a grid."""

    grid: Grid
    cost: npt.NDArray[np.float64]
    clearance_m: npt.NDArray[np.float32]
    """Distance from each cell to the nearest occupied or unknown cell."""


class GridPlanner:
    def __init__(
        self,
        robot_radius_m: float = 0.25,
        inflation_radius_m: float = 0.7,
        cost_scaling: float = 4.0,
        wall_weight: float = 6.0,
    ) -> None:
        self.robot_radius_m = robot_radius_m
        self.inflation_radius_m = inflation_radius_m
        self.cost_scaling = cost_scaling
        self.wall_weight = wall_weight

    def costmap(self, grid: Grid) -> Costmap:
        passable = np.asarray(grid.free, np.uint8)
        clearance = cv2.distanceTransform(passable, cv2.DIST_L2, 5) * np.float32(grid.resolution)
        beyond = np.maximum(clearance - self.robot_radius_m, 0.0)
        cost = 1.0 + self.wall_weight * np.exp(-self.cost_scaling * beyond)
        cost[clearance > self.inflation_radius_m] = 1.0
        cost[clearance <= self.robot_radius_m] = np.inf
        return Costmap(grid, np.asarray(cost, np.float64), np.asarray(clearance, np.float32))

    def plan(self, costmap: Costmap, start: Point, goal: Point) -> list[Point]:
        """Waypoints from ``start`` to ``goal`` (both included), or NoPathError."""
        grid = costmap.grid
        s, g = grid.cell_of(*start), grid.cell_of(*goal)
        if not grid.inside(*g):
            raise NoPathError(OUTSIDE_MAP, "the goal is outside the map")
        if not grid.inside(*s):
            raise NoPathError(START_OCCUPIED, "the robot is outside the map")
        if not math.isfinite(costmap.cost[g]):
            raise NoPathError(GOAL_OCCUPIED, "the goal is occupied on the costmap")
        cost = costmap.cost
        if not math.isfinite(cost[s]):
            if not grid.free[s]:
                raise NoPathError(START_OCCUPIED, "the robot's own cell is occupied")
            cost = _free_near(costmap, s, self.robot_radius_m)  # leave the inflation: a way out
        router = MCP_Geometric(cost, fully_connected=True)
        cumulative, _ = router.find_costs([s], [g])
        if not math.isfinite(float(cumulative[g])):
            raise NoPathError(NO_VALID_PATH, "no valid path: the way to the goal is blocked")
        cells = np.asarray(router.traceback(g), np.float64)
        thin = approximate_polygon(cells, tolerance=SIMPLIFY_CELLS)  # type: ignore[no-untyped-call]
        points = [grid.centre_of(float(r), float(c)) for r, c in thin]
        return [start, *points[1:-1], goal]


def _free_near(costmap: Costmap, cell: tuple[int, int], radius_m: float) -> npt.NDArray[np.float64]:
    """The cost array with the free cells within ``radius_m`` of ``cell`` made passable."""
    grid = costmap.grid
    reach = math.ceil(radius_m / grid.resolution) + 1
    r0, c0 = max(0, cell[0] - reach), max(0, cell[1] - reach)
    r1, c1 = min(grid.height, cell[0] + reach + 1), min(grid.width, cell[1] + reach + 1)
    cost = costmap.cost.copy()
    window = cost[r0:r1, c0:c1]
    free = grid.free[r0:r1, c0:c1]
    window[free & ~np.isfinite(window)] = 1.0 + 6.0
    return cost


def path_length(points: list[Point]) -> float:
    return sum(math.dist(a, b) for a, b in pairwise(points))
