"""Pixel types shared by the model ports (``models.base``) and the mask post-processing."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

Image = npt.NDArray[np.uint8]
"""An RGB frame, shape (H, W, 3), dtype uint8."""

Mask = npt.NDArray[np.bool_]
"""A full-frame boolean mask, shape (H, W)."""

Box = tuple[int, int, int, int]
"""Pixel box (x_min, y_min, x_max, y_max)."""

Point = tuple[int, int]
"""Pixel point (x, y)."""
