"""GrabCutSegmenter: OpenCV GrabCut from a box or point prompt — the default segmenter.

CPU only, no weights. GrabCut runs on a window around the prompt (the box plus ``margin``,
so the background model sees table around the object), downscaled so its longest side is
at most ``max_side`` px, then the mask is mapped back to the full frame and cleaned
(the component under the prompt, holes filled).
"""

from __future__ import annotations

from typing import Any

import cv2
import numpy as np

from robot_mcp_perception.models._checks import check_image, check_points, clip_box
from robot_mcp_perception.models.base import Box, CostClass, Image, Mask, Point, Segmenter
from robot_mcp_perception.postprocess import fill_holes, keep_component


class GrabCutSegmenter(Segmenter):
    cost_class: CostClass = "local"

    def __init__(
        self,
        iterations: int = 3,
        margin: float = 0.2,
        min_margin_px: int = 8,
        max_side: int = 128,
        point_window: float = 0.12,
        point_radius_px: int = 4,
    ) -> None:
        if iterations < 1:
            raise ValueError(f"iterations must be >= 1, got {iterations}")
        if margin < 0 or point_window <= 0:
            raise ValueError("margin must be >= 0 and point_window > 0")
        if max_side < 16:
            raise ValueError(f"max_side must be >= 16, got {max_side}")
        self.iterations = iterations
        self.margin = margin
        self.min_margin_px = min_margin_px
        self.max_side = max_side
        self.point_window = point_window
        self.point_radius_px = point_radius_px

    def segment_box(self, image: Image, box: Box) -> Mask:
        height, width = check_image(image)
        x0, y0, x1, y1 = clip_box(box, width, height)
        mx = max(self.min_margin_px, round(self.margin * (x1 - x0)))
        my = max(self.min_margin_px, round(self.margin * (y1 - y0)))
        window = (max(0, x0 - mx), max(0, y0 - my), min(width, x1 + mx), min(height, y1 + my))
        wx0, wy0, wx1, wy1 = window
        seed = np.full((wy1 - wy0, wx1 - wx0), cv2.GC_BGD, np.uint8)
        seed[y0 - wy0 : y1 - wy0, x0 - wx0 : x1 - wx0] = cv2.GC_PR_FGD
        mask = self._run(image, window, seed)
        return fill_holes(keep_component(mask, (x0, y0, x1, y1)))

    def segment_points(self, image: Image, points: list[Point]) -> Mask:
        height, width = check_image(image)
        pts = check_points(points, width, height)
        reach = max(8, round(self.point_window * min(width, height)))
        xs, ys = [p[0] for p in pts], [p[1] for p in pts]
        window = (
            max(0, min(xs) - reach),
            max(0, min(ys) - reach),
            min(width, max(xs) + reach + 1),
            min(height, max(ys) + reach + 1),
        )
        wx0, wy0, wx1, wy1 = window
        seed = np.full((wy1 - wy0, wx1 - wx0), cv2.GC_PR_BGD, np.uint8)
        seed[[0, -1], :] = cv2.GC_BGD
        seed[:, [0, -1]] = cv2.GC_BGD
        for x, y in pts:
            cv2.circle(seed, (x - wx0, y - wy0), 3 * self.point_radius_px, cv2.GC_PR_FGD, -1)
        for x, y in pts:
            cv2.circle(seed, (x - wx0, y - wy0), self.point_radius_px, cv2.GC_FGD, -1)
        mask = self._run(image, window, seed)
        return fill_holes(keep_component(mask, points=pts))

    def _run(self, image: Image, window: Box, seed: Any) -> Mask:
        """GrabCut on ``window`` initialised from ``seed`` (GC_* labels); full-frame mask."""
        wx0, wy0, wx1, wy1 = window
        crop: Any = np.ascontiguousarray(image[wy0:wy1, wx0:wx1])
        h, w = seed.shape
        scale = min(1.0, self.max_side / max(h, w))
        if scale < 1.0:
            size = (max(2, round(w * scale)), max(2, round(h * scale)))
            crop = cv2.resize(crop, size, interpolation=cv2.INTER_AREA)
            seed = cv2.resize(seed, size, interpolation=cv2.INTER_NEAREST)
        is_fg = (seed == cv2.GC_FGD) | (seed == cv2.GC_PR_FGD)
        if is_fg.all():
            # The prompt covers the whole window (object at the image edge on all sides):
            # GrabCut needs background samples, so the outer ring becomes probable background.
            seed[[0, -1], :] = cv2.GC_PR_BGD
            seed[:, [0, -1]] = cv2.GC_PR_BGD
        bgd = np.zeros((1, 65), np.float64)
        fgd = np.zeros((1, 65), np.float64)
        cv2.grabCut(crop, seed, (0, 0, 0, 0), bgd, fgd, self.iterations, cv2.GC_INIT_WITH_MASK)
        fg = ((seed == cv2.GC_FGD) | (seed == cv2.GC_PR_FGD)).astype(np.float32)
        if scale < 1.0:
            fg = cv2.resize(fg, (w, h), interpolation=cv2.INTER_LINEAR)
        full = np.zeros(image.shape[:2], dtype=bool)
        full[wy0:wy1, wx0:wx1] = fg >= 0.5
        return full
