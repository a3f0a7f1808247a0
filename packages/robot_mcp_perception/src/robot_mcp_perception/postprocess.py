"""Mask post-processing and plausibility (spec 000 §5).

Pure functions on full-frame boolean masks: hole fill, speck removal, keeping the component
under the prompt, the oversized-background filter, and the plausibility check the pipelines
use to decide whether to fall back to the next prompt strategy.
"""

from __future__ import annotations

from typing import Any

import cv2
import numpy as np

from robot_mcp_perception.pixels import Box, Mask, Point


def empty_mask(height: int, width: int) -> Mask:
    return np.zeros((height, width), dtype=bool)


def fill_holes(mask: Mask) -> Mask:
    """Fill background pockets fully enclosed by the mask."""
    if not mask.any():
        return mask.copy()
    padded = np.pad(mask.astype(np.uint8), 1)
    flood = padded.copy()
    cv2.floodFill(flood, None, (0, 0), 1)
    holes = flood[1:-1, 1:-1] == 0
    out: Mask = mask | holes
    return out


def remove_specks(mask: Mask, min_area_px: int) -> Mask:
    """Drop connected components smaller than ``min_area_px`` pixels."""
    if min_area_px <= 1 or not mask.any():
        return mask.copy()
    count, labels, stats, _ = cv2.connectedComponentsWithStats(
        mask.astype(np.uint8), connectivity=8
    )
    keep = np.zeros(count, dtype=bool)
    keep[1:] = stats[1:, cv2.CC_STAT_AREA] >= min_area_px
    out: Mask = keep[labels]
    return out


def keep_component(mask: Mask, box: Box | None = None, points: list[Point] | None = None) -> Mask:
    """Keep the one connected component the prompt refers to.

    Preference: a component under a prompt point; else the component with most pixels inside
    ``box``; else the largest component.
    """
    if not mask.any():
        return mask.copy()
    count, labels, stats, _ = cv2.connectedComponentsWithStats(
        mask.astype(np.uint8), connectivity=8
    )
    if count <= 2:
        return mask.copy()
    chosen = 0
    h, w = mask.shape
    for x, y in points or []:
        if 0 <= x < w and 0 <= y < h and labels[y, x] > 0:
            chosen = int(labels[y, x])
            break
    if chosen == 0 and box is not None:
        x0, y0, x1, y1 = _clip_box(box, w, h)
        inside = np.bincount(labels[y0:y1, x0:x1].ravel(), minlength=count)
        inside[0] = 0
        if inside.max() > 0:
            chosen = int(inside.argmax())
    if chosen == 0:
        chosen = 1 + int(stats[1:, cv2.CC_STAT_AREA].argmax())
    out: Mask = labels == chosen
    return out


def filter_background(mask: Mask, max_fraction: float) -> Mask:
    """The oversized-background filter: a mask covering more than ``max_fraction`` of the
    image is the table, not an object — return an empty mask instead."""
    if mask.size and mask.mean() > max_fraction:
        return np.zeros_like(mask)
    return mask


def clean_mask(
    mask: Mask,
    box: Box | None = None,
    points: list[Point] | None = None,
    *,
    speck_fraction: float = 0.002,
    max_fraction: float = 0.9,
) -> Mask:
    """The standard chain: background filter → speck removal → prompt component → hole fill."""
    mask = filter_background(mask, max_fraction)
    min_px = int(speck_fraction * mask.size)
    return fill_holes(keep_component(remove_specks(mask, min_px), box, points))


def mask_box(mask: Mask) -> Box | None:
    """Tight pixel box (x_min, y_min, x_max, y_max) of a mask, exclusive max; None if empty."""
    ys, xs = np.nonzero(mask)
    if xs.size == 0:
        return None
    return int(xs.min()), int(ys.min()), int(xs.max()) + 1, int(ys.max()) + 1


def mask_centroid(mask: Mask) -> Point | None:
    """A point on the mask near its centroid (the grasp/anchor point); None if empty.

    For non-convex shapes the centroid can fall outside the mask; then the mask pixel
    nearest to it is returned, so the point is always on the object.
    """
    ys, xs = np.nonzero(mask)
    if xs.size == 0:
        return None
    cx, cy = float(xs.mean()), float(ys.mean())
    ix, iy = round(cx), round(cy)
    if mask[iy, ix]:
        return ix, iy
    nearest = int(np.argmin((xs - cx) ** 2 + (ys - cy) ** 2))
    return int(xs[nearest]), int(ys[nearest])


def mask_iou(a: Mask, b: Mask) -> float:
    union = int(np.count_nonzero(a | b))
    return int(np.count_nonzero(a & b)) / union if union else 0.0


def implausibility(
    mask: Mask,
    box: Box | None,
    *,
    min_mask_fraction: float,
    max_mask_fraction: float,
    max_outside_box_fraction: float,
) -> str | None:
    """Why ``mask`` is not a plausible answer to a prompt with ``box``; None when plausible.

    Rejected: empty; smaller than ``min_mask_fraction`` of the box area; leaking out of the
    box (more than ``max_outside_box_fraction`` of its pixels outside the box); covering
    more than ``max_mask_fraction`` of the image.
    """
    area = int(np.count_nonzero(mask))
    if area == 0:
        return "empty"
    if area > max_mask_fraction * mask.size:
        return "covers_image"
    if box is None:
        return None
    h, w = mask.shape
    x0, y0, x1, y1 = _clip_box(box, w, h)
    box_area = max(1, (x1 - x0) * (y1 - y0))
    if area < min_mask_fraction * box_area:
        return "too_small"
    inside = int(np.count_nonzero(mask[y0:y1, x0:x1]))
    if (area - inside) > max_outside_box_fraction * area:
        return "leaks_outside_box"
    return None


def _clip_box(box: Box, width: int, height: int) -> Box:
    x0, y0, x1, y1 = box
    return (
        max(0, min(width, x0)),
        max(0, min(height, y0)),
        max(0, min(width, x1)),
        max(0, min(height, y1)),
    )


def as_uint8(mask: Mask) -> Any:
    """0/255 mono8 rendering of a mask."""
    return mask.astype(np.uint8) * 255
