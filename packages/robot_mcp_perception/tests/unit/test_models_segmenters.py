"""GrabCutSegmenter (the default segmenter) and NullSegmenter."""

from __future__ import annotations

import numpy as np
import pytest

from robot_mcp_perception.models.base import SegmentPrompt
from robot_mcp_perception.models.grabcut import GrabCutSegmenter
from robot_mcp_perception.models.null import NullSegmenter
from robot_mcp_perception.postprocess import mask_iou
from robot_mcp_perception.sample_scenes import polygon_mask, render_scene


def disc_image() -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(0)
    image = (np.full((120, 160, 3), (150, 110, 75)) + rng.normal(0, 4, (120, 160, 3))).astype(
        np.uint8
    )
    yy, xx = np.mgrid[0:120, 0:160]
    truth = (xx - 80) ** 2 + (yy - 60) ** 2 <= 25**2
    image[truth] = (40, 80, 200)
    return image, truth


def test_grabcut_segments_the_object_in_a_box_prompt() -> None:
    image, truth = disc_image()
    mask = GrabCutSegmenter().segment_box(image, (50, 30, 110, 90))
    assert mask.shape == (120, 160)
    assert mask.dtype == bool
    assert mask_iou(mask, truth) > 0.9


def test_grabcut_segments_the_object_under_point_prompts() -> None:
    image, truth = disc_image()
    mask = GrabCutSegmenter(point_window=0.3).segment_points(image, [(80, 60), (85, 62)])
    assert mask_iou(mask, truth) > 0.8


def test_grabcut_is_accurate_on_a_generated_scene() -> None:
    image, doc = render_scene(1, seed=0, size=(320, 240))
    seg = GrabCutSegmenter()
    for ann in doc["annotations"]:
        x, y, w, h = ann["bbox"]
        truth = polygon_mask(ann["segmentation"], 320, 240)
        assert mask_iou(seg.segment_box(image, (x, y, x + w, y + h)), truth) > 0.75, ann["label"]


def test_grabcut_handles_a_box_covering_the_whole_image() -> None:
    image, _ = disc_image()
    mask = GrabCutSegmenter().segment_box(image, (0, 0, 160, 120))
    assert mask.shape == (120, 160)


def test_grabcut_downscales_large_windows_and_keeps_full_resolution_masks() -> None:
    image, truth = disc_image()
    big = np.repeat(np.repeat(image, 4, axis=0), 4, axis=1)
    big_truth = np.repeat(np.repeat(truth, 4, axis=0), 4, axis=1)
    mask = GrabCutSegmenter(max_side=64).segment_box(big, (200, 120, 440, 360))
    assert mask.shape == big_truth.shape
    assert mask_iou(mask, big_truth) > 0.85


def test_grabcut_refuses_bad_inputs_with_clear_errors() -> None:
    image, _ = disc_image()
    seg = GrabCutSegmenter()
    with pytest.raises(ValueError, match="no area inside"):
        seg.segment_box(image, (200, 200, 300, 300))
    with pytest.raises(ValueError, match="RGB uint8"):
        seg.segment_box(image[:, :, 0], (0, 0, 10, 10))
    with pytest.raises(TypeError, match="numpy array"):
        seg.segment_box([[1]], (0, 0, 10, 10))  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="at least one point"):
        seg.segment_points(image, [])
    with pytest.raises(ValueError, match="inside"):
        seg.segment_points(image, [(500, 500)])
    with pytest.raises(ValueError, match="x_min"):
        seg.segment_box(image, (1, 2, 3))  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="empty"):
        seg.segment_box(np.zeros((0, 4, 3), np.uint8), (0, 0, 1, 1))


@pytest.mark.parametrize(
    "kwargs", [{"iterations": 0}, {"margin": -1.0}, {"max_side": 4}, {"point_window": 0.0}]
)
def test_grabcut_refuses_bad_settings(kwargs: dict[str, float]) -> None:
    with pytest.raises(ValueError):
        GrabCutSegmenter(**kwargs)  # type: ignore[arg-type]


def test_null_segmenter_returns_the_box_as_the_mask() -> None:
    image = np.zeros((20, 30, 3), np.uint8)
    mask = NullSegmenter().segment_box(image, (5, 4, 15, 10))
    assert mask.sum() == 60
    assert mask[4:10, 5:15].all()
    clipped = NullSegmenter().segment_box(image, (-5, -5, 3, 3))
    assert clipped.sum() == 9


def test_null_segmenter_marks_squares_around_points() -> None:
    image = np.zeros((20, 30, 3), np.uint8)
    mask = NullSegmenter(point_radius_px=2).segment_points(image, [(10, 10), (99, 99)])
    assert mask.sum() == 25
    with pytest.raises(ValueError):
        NullSegmenter(point_radius_px=0)


def test_segment_many_defaults_to_one_mask_per_prompt() -> None:
    image = np.zeros((20, 30, 3), np.uint8)
    masks = NullSegmenter(point_radius_px=1).segment_many(
        image, [SegmentPrompt(box=(0, 0, 2, 2)), SegmentPrompt(points=[(10, 10)])]
    )
    assert [int(m.sum()) for m in masks] == [4, 9]
