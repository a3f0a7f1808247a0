"""NullSegmenter (``segmenter=none``): box-shaped masks, for no-GPU development and tests."""

from __future__ import annotations

import numpy as np

from robot_mcp_perception.models._checks import check_image, check_points, clip_box
from robot_mcp_perception.models.base import Box, CostClass, Image, Mask, Point, Segmenter


class NullSegmenter(Segmenter):
    """Returns the prompt box as the mask; for points, a square of ``point_radius_px`` around
    each point. No model, no weights, instant."""

    cost_class: CostClass = "local"

    def __init__(self, point_radius_px: int = 8) -> None:
        if point_radius_px < 1:
            raise ValueError(f"point_radius_px must be >= 1, got {point_radius_px}")
        self.point_radius_px = point_radius_px

    def segment_box(self, image: Image, box: Box) -> Mask:
        height, width = check_image(image)
        x0, y0, x1, y1 = clip_box(box, width, height)
        mask = np.zeros((height, width), dtype=bool)
        mask[y0:y1, x0:x1] = True
        return mask

    def segment_points(self, image: Image, points: list[Point]) -> Mask:
        height, width = check_image(image)
        mask = np.zeros((height, width), dtype=bool)
        r = self.point_radius_px
        for x, y in check_points(points, width, height):
            mask[max(0, y - r) : y + r + 1, max(0, x - r) : x + r + 1] = True
        return mask
