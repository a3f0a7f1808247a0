"""The scripted fakes shipped beside the real adapters."""

from __future__ import annotations

import numpy as np
import pytest

from robot_mcp_perception.models.base import (
    GroundedTarget,
    GroundingResult,
    ModelError,
    SegmentPrompt,
    SemanticRequest,
)
from robot_mcp_perception.models.fakes import FakeGrounder, FakeSegmenter

IMAGE = np.zeros((20, 30, 3), np.uint8)
MUG = GroundedTarget("mug", (1, 2, 5, 6), [(3, 4)])


async def test_fake_grounder_records_calls_and_repeats_a_single_result() -> None:
    result = GroundingResult("a mug", targets=[MUG])
    fake = FakeGrounder(result)
    assert (
        await fake.ground(IMAGE, "mug", [SemanticRequest("found", "boolean")], "describe") is result
    )
    assert await fake.point(IMAGE, "mug") == [MUG]
    assert fake.ground_calls == 1
    assert fake.point_calls == 1
    assert fake.calls[0].outputs == [SemanticRequest("found", "boolean")]
    assert fake.calls[0].mode == "describe"
    assert fake.calls[1].image_shape == (20, 30, 3)
    assert fake.cost_class == "cloud"


async def test_fake_grounder_plays_a_sequence_and_raises_scripted_errors() -> None:
    first, last = GroundingResult("1"), GroundingResult("2")
    fake = FakeGrounder([first, ModelError("boom"), last])
    assert (await fake.ground(IMAGE, "q")).answer == "1"
    with pytest.raises(ModelError, match="boom"):
        await fake.ground(IMAGE, "q")
    assert (await fake.ground(IMAGE, "q")).answer == "2"
    assert (await fake.ground(IMAGE, "q")).answer == "2"
    assert (await FakeGrounder([]).ground(IMAGE, "q")) == GroundingResult()


async def test_fake_grounder_can_answer_from_a_callable_and_fail_or_be_slow() -> None:
    fake = FakeGrounder(lambda image, question, mode: GroundingResult(f"{question}/{mode}"))
    assert (await fake.ground(IMAGE, "q", mode="region")).answer == "q/region"
    with pytest.raises(ModelError):
        await FakeGrounder(error=ModelError("down")).ground(IMAGE, "q")
    slow = FakeGrounder(GroundingResult("late"), delay_s=0.01, cost_class="local")
    assert (await slow.ground(IMAGE, "q")).answer == "late"
    assert slow.cost_class == "local"


def test_fake_segmenter_returns_box_masks_and_counts_calls() -> None:
    fake = FakeSegmenter(point_radius_px=1)
    assert fake.segment_box(IMAGE, (0, 0, 4, 5)).sum() == 20
    assert fake.segment_points(IMAGE, [(10, 10)]).sum() == 9
    masks = fake.segment_many(
        IMAGE, [SegmentPrompt(box=(0, 0, 2, 2)), SegmentPrompt(points=[(5, 5)])]
    )
    assert [int(m.sum()) for m in masks] == [4, 9]
    assert [c.method for c in fake.calls] == ["box", "points", "many"]
    assert fake.call_count == 3


def test_fake_segmenter_can_script_masks() -> None:
    fake = FakeSegmenter(masks=lambda image, prompt: np.ones(image.shape[:2], bool))
    assert fake.segment_box(IMAGE, (0, 0, 1, 1)).all()
