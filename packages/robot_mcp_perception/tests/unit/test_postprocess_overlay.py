"""viz.render_overlay: masks, boxes, points, labels and outputs drawn on a copy of the frame."""

from __future__ import annotations

import numpy as np
import pytest

from robot_mcp_perception.pipelines.common import Detection, SkillResult
from robot_mcp_perception.viz import REGION_COLOUR, colour_of, render_overlay


def test_the_overlay_draws_masks_boxes_points_and_outputs_on_a_copy() -> None:
    image = np.zeros((120, 160, 3), np.uint8)
    mask = np.zeros((120, 160), bool)
    mask[40:80, 40:80] = True
    result = SkillResult(
        detections=[
            Detection("mug", 0.9, "object", (40, 40, 80, 80), mask, (60, 60)),
            Detection("space", 1.0, "region", (100, 10, 150, 50), None, (125, 30)),
            Detection("", 0.3, "object", (5, 90, 20, 110), None, None, {"mask_failed": True}),
        ],
        outputs={"found": True},
    )
    out = render_overlay(image, result)
    assert out.shape == image.shape
    assert out.dtype == np.uint8
    assert not image.any()  # the input is untouched
    assert out[70, 50].any()  # mask tinted
    assert tuple(out[30, 100]) == REGION_COLOUR  # region box edge
    assert tuple(out[60, 60]) == colour_of(0)  # point
    assert out[0:20, 0:60].any()  # outputs text


def test_the_overlay_refuses_non_rgb_images() -> None:
    with pytest.raises(ValueError, match="RGB"):
        render_overlay(np.zeros((4, 4), np.uint8), SkillResult())


def test_an_empty_result_gives_the_frame_back() -> None:
    image = np.full((20, 20, 3), 7, np.uint8)
    assert np.array_equal(render_overlay(image, SkillResult()), image)
