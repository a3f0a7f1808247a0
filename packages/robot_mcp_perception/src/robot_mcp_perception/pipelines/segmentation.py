"""Turning a grounded target into a full-frame mask, with the spec's fallback chain.

Order (spec 000 §5): crop around the box (``crop_margin``) → box prompt in the crop, mapped
back to the full frame (a crop answer covering more than ``max_mask_fraction`` of the crop
is background: ``covers_crop``); if implausible → full-image box prompt; if implausible → point
prompt(s); if still implausible → no mask (the detection keeps its box and point and says
``extra["mask_failed"] = True`` with the rejection reasons). Every mask is cleaned
(:func:`~robot_mcp_perception.postprocess.clean_mask`) before the plausibility check.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import structlog

from robot_mcp_perception.models.base import (
    Box,
    GroundedTarget,
    Image,
    Mask,
    ModelError,
    Point,
)
from robot_mcp_perception.pipelines.common import (
    Detection,
    PipelineContext,
    PipelineSettings,
    call_segmenter,
)
from robot_mcp_perception.postprocess import clean_mask, implausibility, mask_box, mask_centroid

log = structlog.get_logger(__name__)


@dataclass
class MaskOutcome:
    mask: Mask | None
    prompt: str = ""
    """Which prompt produced the mask: crop_box | full_box | points | batch."""
    rejections: list[str] = field(default_factory=list)


def sanitize_box(box: Box | None, width: int, height: int) -> Box | None:
    """The box clipped to the image, or None when it is missing or has no area inside."""
    if box is None:
        return None
    x0, y0, x1, y1 = (int(v) for v in box)
    x0, x1 = sorted((max(0, min(width, x0)), max(0, min(width, x1))))
    y0, y1 = sorted((max(0, min(height, y0)), max(0, min(height, y1))))
    return (x0, y0, x1, y1) if x1 - x0 >= 2 and y1 - y0 >= 2 else None


def prompt_points(target: GroundedTarget, box: Box | None, width: int, height: int) -> list[Point]:
    points = [(int(x), int(y)) for x, y in target.points if 0 <= x < width and 0 <= y < height]
    if not points and box is not None:
        points = [((box[0] + box[2]) // 2, (box[1] + box[3]) // 2)]
    return points


def expand_box(box: Box, margin: float, width: int, height: int) -> Box:
    x0, y0, x1, y1 = box
    mx, my = round(margin * (x1 - x0)), round(margin * (y1 - y0))
    return max(0, x0 - mx), max(0, y0 - my), min(width, x1 + mx), min(height, y1 + my)


def accept(
    mask: Any,
    box: Box | None,
    points: list[Point],
    settings: PipelineSettings,
    shape: tuple[int, int],
) -> tuple[Mask | None, str | None]:
    """Clean a segmenter answer and check it; (mask, None) when plausible else (None, reason)."""
    if not isinstance(mask, np.ndarray) or mask.shape != shape:
        got = getattr(mask, "shape", type(mask).__name__)
        return None, f"bad_mask_shape:{got}"
    cleaned = clean_mask(
        mask.astype(bool),
        box,
        points,
        speck_fraction=settings.speck_fraction,
        max_fraction=settings.max_mask_fraction,
    )
    reason = implausibility(
        cleaned,
        box,
        min_mask_fraction=settings.min_mask_fraction,
        max_mask_fraction=settings.max_mask_fraction,
        max_outside_box_fraction=settings.max_outside_box_fraction,
    )
    return (cleaned, None) if reason is None else (None, reason)


async def segment_target(
    image: Image,
    target: GroundedTarget,
    ctx: PipelineContext,
    skill: str,
    timings: dict[str, float],
) -> MaskOutcome:
    """The fallback chain for one target (ground_and_segment)."""
    height, width = image.shape[:2]
    box = sanitize_box(target.box, width, height)
    points = prompt_points(target, box, width, height)
    outcome = MaskOutcome(None)
    seg = ctx.segmenter

    async def attempt(name: str, fn: Any, *args: Any, crop: Box | None = None) -> bool:
        try:
            raw = await call_segmenter("segment", skill, seg, timings, fn, *args)
        except (ModelError, ValueError) as exc:
            log.warning("segment_attempt_failed", skill=skill, prompt=name, error=str(exc))
            outcome.rejections.append(f"{name}:error")
            return False
        if crop is not None:
            if (
                isinstance(raw, np.ndarray)
                and raw.size
                and raw.mean() > ctx.settings.max_mask_fraction
            ):
                log.info("mask_rejected", skill=skill, prompt=name, reason="covers_crop")
                outcome.rejections.append(f"{name}:covers_crop")
                return False
            raw = _paste(raw, crop, (height, width))
        mask, reason = accept(raw, box, points, ctx.settings, (height, width))
        if mask is None:
            log.info("mask_rejected", skill=skill, prompt=name, reason=reason)
            outcome.rejections.append(f"{name}:{reason}")
            return False
        outcome.mask, outcome.prompt = mask, name
        return True

    if box is not None:
        crop = expand_box(box, ctx.settings.crop_margin, width, height)
        cx0, cy0, cx1, cy1 = crop
        crop_image = np.ascontiguousarray(image[cy0:cy1, cx0:cx1])
        local = (box[0] - cx0, box[1] - cy0, box[2] - cx0, box[3] - cy0)
        if await attempt("crop_box", seg.segment_box, crop_image, local, crop=crop):
            return outcome
        if await attempt("full_box", seg.segment_box, image, box):
            return outcome
    if points and await attempt("points", seg.segment_points, image, points):
        return outcome
    return outcome


def _paste(local: Any, crop: Box, shape: tuple[int, int]) -> Any:
    """A crop-sized mask placed into a full-frame mask (anything else is returned as is)."""
    cx0, cy0, cx1, cy1 = crop
    if not isinstance(local, np.ndarray) or local.shape != (cy1 - cy0, cx1 - cx0):
        return local
    full = np.zeros(shape, dtype=bool)
    full[cy0:cy1, cx0:cx1] = local.astype(bool)
    return full


def object_detection(
    target: GroundedTarget, outcome: MaskOutcome | None, shape: tuple[int, int]
) -> Detection:
    """A Detection for a target; with ``outcome`` None, segmentation was not requested."""
    height, width = shape
    box = sanitize_box(target.box, width, height)
    mask = outcome.mask if outcome is not None else None
    if box is None and mask is not None:
        box = mask_box(mask)
    point = mask_centroid(mask) if mask is not None else None
    if point is None:
        pts = prompt_points(target, box, width, height)
        point = pts[0] if pts else None
    extra: dict[str, Any] = {}
    if outcome is not None:
        if mask is None:
            extra["mask_failed"] = True
        else:
            extra["prompt"] = outcome.prompt
        if outcome.rejections:
            extra["mask_rejections"] = list(outcome.rejections)
    score = target.confidence if target.confidence is not None else 1.0
    return Detection(target.label, float(score), "object", box, mask, point, extra)
