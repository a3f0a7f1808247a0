"""Input checks shared by the adapters: every bad input gets a clear error."""

from __future__ import annotations

import numpy as np

from robot_mcp_perception.models.base import Box, Image, Point


def check_image(image: Image) -> tuple[int, int]:
    """Validate an RGB uint8 (H, W, 3) frame; returns (height, width)."""
    if not isinstance(image, np.ndarray):
        raise TypeError(f"image must be a numpy array, got {type(image).__name__}")
    if image.dtype != np.uint8 or image.ndim != 3 or image.shape[2] != 3:
        raise ValueError(f"image must be RGB uint8 (H, W, 3), got {image.dtype} {image.shape}")
    height, width = int(image.shape[0]), int(image.shape[1])
    if height == 0 or width == 0:
        raise ValueError("image is empty")
    return height, width


def clip_box(box: Box, width: int, height: int) -> Box:
    """Clip an (x0, y0, x1, y1) box (exclusive max) to the image; ValueError if nothing is left."""
    if len(box) != 4:
        raise ValueError(f"box must be (x_min, y_min, x_max, y_max), got {box!r}")
    x0, y0, x1, y1 = (int(v) for v in box)
    cx0, cy0 = max(0, min(width, x0)), max(0, min(height, y0))
    cx1, cy1 = max(0, min(width, x1)), max(0, min(height, y1))
    if cx1 <= cx0 or cy1 <= cy0:
        raise ValueError(f"box {box!r} has no area inside the {width}x{height} image")
    return cx0, cy0, cx1, cy1


def check_points(points: list[Point], width: int, height: int) -> list[Point]:
    """Points inside the image; ValueError when none is given or none is inside."""
    if not points:
        raise ValueError("at least one point prompt is required")
    inside = [(int(x), int(y)) for x, y in points if 0 <= x < width and 0 <= y < height]
    if not inside:
        raise ValueError(f"no point of {points!r} lies inside the {width}x{height} image")
    return inside
