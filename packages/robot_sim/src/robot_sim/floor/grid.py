"""An occupancy grid loaded the way map_server loads a map (``map.yaml`` + image).

Supported: ``mode`` trinary (default), scale and raw; ``negate``; ``occupied_thresh`` /
``free_thresh``; ``origin`` [x, y, yaw] with yaw 0 (Nav2 ignores any other yaw too). Values
are ``nav_msgs/OccupancyGrid``'s: 0 free, 100 occupied, -1 unknown (scale mode: 1..99 in
between); row 0 of :attr:`Grid.cells` is the map's bottom row (the message's order).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import numpy.typing as npt
import yaml

from robot_sim.floor.plan import Box, FloorError

OCCUPIED, FREE, UNKNOWN = 100, 0, -1

Cells = npt.NDArray[np.int8]
Mask = npt.NDArray[np.bool_]


@dataclass(frozen=True)
class Grid:
    cells: Cells
    """(height, width) int8, row 0 = lowest y (OccupancyGrid order)."""
    resolution: float
    origin: tuple[float, float]

    @property
    def height(self) -> int:
        return int(self.cells.shape[0])

    @property
    def width(self) -> int:
        return int(self.cells.shape[1])

    @property
    def occupied(self) -> Mask:
        return np.asarray(self.cells == OCCUPIED)

    @property
    def free(self) -> Mask:
        return np.asarray(self.cells == FREE)

    def cell_of(self, x: float, y: float) -> tuple[int, int]:
        """(row, col) of the cell holding (x, y); may lie outside the grid."""
        col = math.floor((x - self.origin[0]) / self.resolution)
        row = math.floor((y - self.origin[1]) / self.resolution)
        return row, col

    def centre_of(self, row: float, col: float) -> tuple[float, float]:
        return (
            self.origin[0] + (col + 0.5) * self.resolution,
            self.origin[1] + (row + 0.5) * self.resolution,
        )

    def inside(self, row: int, col: int) -> bool:
        return 0 <= row < self.height and 0 <= col < self.width

    def box_mask(self, box: Box) -> Mask:
        """The cells whose centres lie inside ``box``."""
        x0, y0, x1, y1 = box
        mask = np.zeros(self.cells.shape, bool)
        c0 = max(0, math.ceil((x0 - self.origin[0]) / self.resolution - 0.5))
        c1 = min(self.width, math.floor((x1 - self.origin[0]) / self.resolution - 0.5) + 1)
        r0 = max(0, math.ceil((y0 - self.origin[1]) / self.resolution - 0.5))
        r1 = min(self.height, math.floor((y1 - self.origin[1]) / self.resolution - 0.5) + 1)
        if c1 > c0 and r1 > r0:
            mask[r0:r1, c0:c1] = True
        return mask

    def with_occupied(self, mask: Mask) -> Grid:
        cells = self.cells.copy()
        cells[mask] = OCCUPIED
        return Grid(cells, self.resolution, self.origin)


def load_grid(yaml_path: Path) -> Grid:
    """Read map_server's ``map.yaml`` and its image; every problem is a FloorError."""
    try:
        meta: Any = yaml.safe_load(yaml_path.read_text(encoding="utf-8"))
    except FileNotFoundError as exc:
        raise FloorError(f"map file not found: {yaml_path}") from exc
    except (OSError, yaml.YAMLError) as exc:
        raise FloorError(f"cannot read map file {yaml_path}: {exc}") from exc
    if not isinstance(meta, dict):
        raise FloorError(f"{yaml_path}: the map must be a YAML mapping")
    try:
        image_name = str(meta["image"])
        resolution = float(meta["resolution"])
        origin = [float(v) for v in meta["origin"]]
        negate = int(meta.get("negate", 0))
        occupied_thresh = float(meta.get("occupied_thresh", 0.65))
        free_thresh = float(meta.get("free_thresh", 0.25))
        mode = str(meta.get("mode", "trinary"))
    except (KeyError, TypeError, ValueError) as exc:
        raise FloorError(f"{yaml_path}: invalid map_server map: {exc!r}") from exc
    if resolution <= 0 or len(origin) != 3 or mode not in ("trinary", "scale", "raw"):
        raise FloorError(
            f"{yaml_path}: resolution must be positive, origin [x, y, yaw], "
            "mode trinary, scale or raw"
        )
    if origin[2] != 0.0:
        raise FloorError(f"{yaml_path}: a rotated origin (yaw {origin[2]}) is not supported")
    image_path = yaml_path.parent / image_name
    pixels = cv2.imread(str(image_path), cv2.IMREAD_GRAYSCALE)
    if pixels is None:
        raise FloorError(f"{yaml_path}: map image {image_path} is missing or unreadable")
    cells = _cells(np.asarray(pixels), mode, negate, occupied_thresh, free_thresh)
    return Grid(np.ascontiguousarray(cells[::-1]), resolution, (origin[0], origin[1]))


def _cells(pixels: npt.NDArray[np.uint8], mode: str, negate: int, occ: float, free: float) -> Cells:
    if mode == "raw":
        values = pixels.astype(np.int16)
        return np.where(values > 100, UNKNOWN, values).astype(np.int8)
    shade = pixels.astype(np.float64) / 255.0
    p = shade if negate else 1.0 - shade
    cells = np.full(pixels.shape, UNKNOWN, np.int8)
    cells[p > occ] = OCCUPIED
    cells[p < free] = FREE
    if mode == "scale":
        between = (p >= free) & (p <= occ)
        cells[between] = np.round(99 * (p[between] - free) / (occ - free)).astype(np.int8)
    return cells
