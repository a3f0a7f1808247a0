"""Mask post-processing and the plausibility check."""

from __future__ import annotations

import numpy as np

from robot_mcp_perception.postprocess import (
    as_uint8,
    clean_mask,
    fill_holes,
    filter_background,
    implausibility,
    keep_component,
    mask_box,
    mask_centroid,
    mask_iou,
    remove_specks,
)

LIMITS = {"min_mask_fraction": 0.05, "max_mask_fraction": 0.9, "max_outside_box_fraction": 0.5}


def ring() -> np.ndarray:
    mask = np.zeros((40, 40), bool)
    mask[10:30, 10:30] = True
    mask[15:25, 15:25] = False
    return mask


def test_fill_holes_closes_enclosed_pockets_only() -> None:
    filled = fill_holes(ring())
    assert filled[20, 20]
    assert filled.sum() == 400
    assert not fill_holes(np.zeros((5, 5), bool)).any()


def test_remove_specks_drops_small_components() -> None:
    mask = ring()
    mask[0, 0] = True
    cleaned = remove_specks(mask, min_area_px=5)
    assert not cleaned[0, 0]
    assert cleaned.sum() == ring().sum()
    assert remove_specks(mask, 1).sum() == mask.sum()


def test_keep_component_prefers_the_point_then_the_box_then_the_largest() -> None:
    mask = np.zeros((40, 40), bool)
    mask[0:5, 0:5] = True  # small, top-left
    mask[20:40, 20:40] = True  # large, bottom-right
    assert keep_component(mask, points=[(2, 2)]).sum() == 25
    assert keep_component(mask, box=(0, 0, 6, 6)).sum() == 25
    assert keep_component(mask).sum() == 400
    assert keep_component(np.zeros((4, 4), bool)).sum() == 0


def test_the_background_filter_empties_masks_covering_most_of_the_image() -> None:
    mask = np.ones((10, 10), bool)
    assert not filter_background(mask, 0.9).any()
    mask[:, :5] = False
    assert filter_background(mask, 0.9).sum() == 50


def test_clean_mask_chains_filter_specks_component_and_holes() -> None:
    mask = ring()
    mask[0, 39] = True
    cleaned = clean_mask(mask, (10, 10, 30, 30), speck_fraction=0.002)
    assert cleaned.sum() == 400


def test_box_centroid_and_iou_of_masks() -> None:
    mask = np.zeros((10, 10), bool)
    mask[2:4, 3:7] = True
    assert mask_box(mask) == (3, 2, 7, 4)
    assert mask_box(np.zeros((3, 3), bool)) is None
    assert mask_centroid(mask) in {(4, 2), (5, 2), (4, 3), (5, 3)}
    assert mask_centroid(np.zeros((3, 3), bool)) is None
    assert mask_iou(mask, mask) == 1.0
    assert mask_iou(mask, np.zeros_like(mask)) == 0.0
    assert mask_iou(np.zeros_like(mask), np.zeros_like(mask)) == 0.0
    assert as_uint8(mask).max() == 255


def test_the_centroid_of_a_non_convex_mask_lies_on_the_mask() -> None:
    assert ring()[mask_centroid(ring())[::-1]]  # type: ignore[index]


def test_plausible_masks_pass_the_check() -> None:
    mask = np.zeros((100, 100), bool)
    mask[20:40, 20:40] = True
    assert implausibility(mask, (18, 18, 42, 42), **LIMITS) is None
    assert implausibility(mask, None, **LIMITS) is None


def test_implausible_masks_are_rejected_with_a_reason() -> None:
    empty = np.zeros((100, 100), bool)
    assert implausibility(empty, (0, 0, 10, 10), **LIMITS) == "empty"
    tiny = empty.copy()
    tiny[50, 50] = True
    assert implausibility(tiny, (0, 0, 100, 50), **LIMITS) == "too_small"
    leak = empty.copy()
    leak[0:60, 0:60] = True
    assert implausibility(leak, (0, 0, 20, 20), **LIMITS) == "leaks_outside_box"
    assert implausibility(np.ones((100, 100), bool), (0, 0, 100, 100), **LIMITS) == "covers_image"
