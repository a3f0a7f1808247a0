"""Overlay rendering for ``/vision/{skill}/overlay`` and the artifacts endpoint.

:func:`render_overlay` draws a :class:`SkillResult` onto a copy of the frame: translucent
masks, boxes (regions dashed-looking thin green, objects in the instance colour), points,
labels with scores, and the semantic outputs as text lines in the top-left corner.
"""

from __future__ import annotations

import json
from typing import Any

import cv2
import numpy as np

from robot_mcp_perception.models.base import Image
from robot_mcp_perception.pipelines.common import Detection, SkillResult

PALETTE: tuple[tuple[int, int, int], ...] = (
    (230, 25, 75),
    (60, 180, 75),
    (255, 225, 25),
    (0, 130, 200),
    (245, 130, 48),
    (145, 30, 180),
    (70, 240, 240),
    (240, 50, 230),
    (210, 245, 60),
    (250, 190, 190),
)
REGION_COLOUR = (0, 220, 120)


def colour_of(index: int) -> tuple[int, int, int]:
    return PALETTE[index % len(PALETTE)]


def render_overlay(
    image: Image, result: SkillResult, alpha: float = 0.45, show_outputs: bool = True
) -> Image:
    """An RGB uint8 copy of ``image`` with ``result`` drawn on it (same shape)."""
    if image.ndim != 3 or image.shape[2] != 3 or image.dtype != np.uint8:
        raise ValueError(f"image must be RGB uint8 (H, W, 3), got {image.dtype} {image.shape}")
    canvas: Any = image.copy()
    for i, det in enumerate(result.detections):
        if det.mask is not None and det.mask.shape == canvas.shape[:2] and det.mask.any():
            colour = np.asarray(colour_of(i), np.float32)
            sel = det.mask
            canvas[sel] = (canvas[sel] * (1 - alpha) + colour * alpha).astype(np.uint8)
    thickness = max(1, round(min(canvas.shape[:2]) / 240))
    for i, det in enumerate(result.detections):
        _draw_detection(canvas, det, i, thickness)
    if show_outputs and result.outputs:
        y = 14 * thickness
        for name, value in result.outputs.items():
            _text(canvas, f"{name}: {json.dumps(value)}"[:80], (4, y), (255, 255, 255), thickness)
            y += 14 * thickness
    out: Image = canvas
    return out


def _draw_detection(canvas: Any, det: Detection, index: int, thickness: int) -> None:
    colour = REGION_COLOUR if det.kind == "region" else colour_of(index)
    if det.box is not None:
        x0, y0, x1, y1 = det.box
        cv2.rectangle(canvas, (x0, y0), (max(x0, x1 - 1), max(y0, y1 - 1)), colour, thickness)
        caption = f"{det.label} {det.score:.2f}" if det.label else f"{det.score:.2f}"
        if det.extra.get("mask_failed"):
            caption += " (no mask)"
        _text(canvas, caption, (x0 + 2, max(10, y0 - 3)), colour, thickness)
    if det.point is not None:
        cv2.circle(canvas, det.point, 3 * thickness, (255, 255, 255), -1)
        cv2.circle(canvas, det.point, 2 * thickness, colour, -1)


def _text(
    canvas: Any, text: str, origin: tuple[int, int], colour: tuple[int, int, int], thickness: int
) -> None:
    scale = 0.35 * thickness
    cv2.putText(
        canvas, text, origin, cv2.FONT_HERSHEY_SIMPLEX, scale, (0, 0, 0), thickness + 1, cv2.LINE_AA
    )
    cv2.putText(
        canvas, text, origin, cv2.FONT_HERSHEY_SIMPLEX, scale, colour, thickness, cv2.LINE_AA
    )
