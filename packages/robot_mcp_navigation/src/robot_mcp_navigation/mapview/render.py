"""The robot's map for a display: small PNG masks of the walls and of the unknown, the
rectangles the costmap blocks where the map is free (a closed door, an obstacle the robot
saw), the mapped area's bounds, and the plan thinned to a few hundred points. Pure."""

from __future__ import annotations

import base64
import hashlib
from typing import Any

import cv2
import numpy as np
import numpy.typing as npt

from robot_mcp_navigation.mapview.base import GridSnapshot, PathSnapshot

OCCUPIED_AT = 65
"""An OccupancyGrid value at least this is drawn as wall (map_server's occupied_thresh 0.65)."""
LETHAL = 100
"""Nav2's costmap as an OccupancyGrid: 100 lethal, 99 inscribed, 1..98 inflated."""
MIN_BLOCKED_CELLS = 2
MAX_PLAN_POINTS = 200


def _cells(grid: GridSnapshot) -> npt.NDArray[np.int8]:
    return np.frombuffer(grid.cells, np.int8).reshape(grid.height, grid.width)


def _png(mask: npt.NDArray[np.bool_]) -> str:
    """A 1-channel PNG (white = set), top row = the map's largest y, base64."""
    ok, encoded = cv2.imencode(
        ".png", np.where(mask[::-1], 255, 0).astype(np.uint8), [cv2.IMWRITE_PNG_BILEVEL, 1]
    )
    if not ok:
        raise ValueError("cannot encode the map as PNG")
    return base64.b64encode(encoded.tobytes()).decode("ascii")


def _box(grid: GridSnapshot, col: int, row: int, width: int, height: int) -> dict[str, float]:
    x0 = grid.origin[0] + col * grid.resolution
    y0 = grid.origin[1] + row * grid.resolution
    return {
        "x0": round(x0, 3),
        "y0": round(y0, 3),
        "x1": round(x0 + width * grid.resolution, 3),
        "y1": round(y0 + height * grid.resolution, 3),
    }


def blocked_boxes(grid: GridSnapshot, costmap: GridSnapshot | None) -> list[dict[str, float]]:
    """Rectangles lethal on the costmap but free on the map, when both share one grid."""
    if costmap is None or (costmap.width, costmap.height, costmap.resolution, costmap.origin) != (
        grid.width, grid.height, grid.resolution, grid.origin,
    ):  # fmt: skip
        return []
    blocked = (_cells(costmap) == LETHAL) & (_cells(grid) == 0)
    count, _, stats, _ = cv2.connectedComponentsWithStats(blocked.astype(np.uint8), connectivity=8)
    return [
        _box(grid, int(x), int(y), int(w), int(h))
        for x, y, w, h, area in stats[1:count]
        if area >= MIN_BLOCKED_CELLS
    ]


def floor_view(grid: GridSnapshot, costmap: GridSnapshot | None) -> dict[str, Any]:
    cells = _cells(grid)
    known = cells >= 0
    rows, cols = np.nonzero(known)
    if rows.size:
        bounds = _box(
            grid,
            int(cols.min()),
            int(rows.min()),
            int(cols.max() - cols.min() + 1),
            int(rows.max() - rows.min() + 1),
        )
    else:
        bounds = _box(grid, 0, 0, grid.width, grid.height)
    walls = _png(cells >= OCCUPIED_AT)
    unknown = _png(~known)
    blocked = blocked_boxes(grid, costmap)
    version = hashlib.sha256(f"{walls}{unknown}{blocked}".encode()).hexdigest()[:12]
    return {
        "available": True,
        "frame": grid.frame,
        "resolution": grid.resolution,
        "origin": {"x": grid.origin[0], "y": grid.origin[1]},
        "width": grid.width,
        "height": grid.height,
        "bounds": bounds,
        "walls_png": walls,
        "unknown_png": unknown,
        "blocked": blocked,
        "version": version,
    }


def plan_points(plan: PathSnapshot) -> list[list[float]]:
    """The plan's points (at most MAX_PLAN_POINTS, first and last kept), rounded to cm."""
    points = plan.points
    if len(points) > MAX_PLAN_POINTS:
        step = (len(points) - 1) / (MAX_PLAN_POINTS - 1)
        points = tuple(points[round(i * step)] for i in range(MAX_PLAN_POINTS))
    return [[round(x, 2), round(y, 2)] for x, y in points]
