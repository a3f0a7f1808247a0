"""Free space on the table: the largest axis-aligned rectangle that overlaps no object."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from robot_mcp_perception.models.base import Box


def largest_free_rect(
    width: int, height: int, obstacles: Sequence[Box], margin_px: int = 8, cell_px: int = 8
) -> Box | None:
    """Largest rectangle of the image (on a ``cell_px`` grid) clear of every obstacle box
    grown by ``margin_px``; None when the image is fully occupied."""
    cols, rows = max(1, width // cell_px), max(1, height // cell_px)
    busy = np.zeros((rows, cols), dtype=bool)
    for x0, y0, x1, y1 in obstacles:
        c0 = max(0, (x0 - margin_px) // cell_px)
        r0 = max(0, (y0 - margin_px) // cell_px)
        c1 = min(cols, -(-(x1 + margin_px) // cell_px))
        r1 = min(rows, -(-(y1 + margin_px) // cell_px))
        busy[r0:r1, c0:c1] = True
    heights = np.zeros(cols, dtype=np.int64)
    best_area, best = 0, None
    for r in range(rows):
        heights = np.where(busy[r], 0, heights + 1)
        stack: list[int] = []
        for c in range(cols + 1):
            h = int(heights[c]) if c < cols else 0
            while stack and int(heights[stack[-1]]) >= h:
                top = stack.pop()
                left = stack[-1] + 1 if stack else 0
                area = int(heights[top]) * (c - left)
                if area > best_area:
                    best_area = area
                    best = (left, r - int(heights[top]) + 1, c, r + 1)
            stack.append(c)
    if best is None:
        return None
    c0, r0, c1, r1 = best
    return c0 * cell_px, r0 * cell_px, min(width, c1 * cell_px), min(height, r1 * cell_px)
