"""Spec 000 §9 item 2 — the reason pipeline through the router: describe, ground_and_segment
(crop → box prompt, fallbacks, plausibility) and region."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
import structlog

from robot_mcp_perception.models.base import (
    GroundedTarget,
    GroundingResult,
    ModelError,
    SegmentPrompt,
)
from robot_mcp_perception.models.fakes import FakeGrounder, FakeSegmenter
from robot_mcp_perception.models.null import NullSegmenter
from robot_mcp_perception.pipelines import run_skill
from robot_mcp_perception.pipelines.common import PipelineContext, PipelineSettings, SkillModeError
from robot_mcp_perception.skills import Skill, SkillOutput

IMAGE = np.zeros((120, 160, 3), np.uint8)
MUG = GroundedTarget("red mug", (40, 30, 80, 70), [(60, 50)], confidence=0.8)
FIND = Skill(
    "find",
    "ground_and_segment",
    grounding="the red mug",
    segment=True,
    outputs=(SkillOutput("found", "boolean"),),
)


def ctx(grounder: FakeGrounder, segmenter: Any = None, **settings: Any) -> PipelineContext:
    return PipelineContext(grounder, segmenter or FakeSegmenter(), PipelineSettings(**settings))


def empty(image: Any, prompt: SegmentPrompt) -> np.ndarray:
    return np.zeros(image.shape[:2], bool)


async def test_ground_and_segment_prompts_the_segmenter_with_the_box_inside_a_crop() -> None:
    seg = FakeSegmenter()
    result = await run_skill(
        FIND, IMAGE, ctx(FakeGrounder(GroundingResult(targets=[MUG])), seg, crop_margin=0.25)
    )
    [call] = seg.calls
    assert call.method == "box"
    assert call.image_shape == (60, 60, 3)  # 40x40 box + 25 % margin on each side
    assert call.prompt == (10, 10, 50, 50)
    [det] = result.detections
    assert det.mask is not None
    assert det.mask.shape == (120, 160)
    assert det.mask[30:70, 40:80].all()
    assert det.mask.sum() == 1600
    assert det.box == (40, 30, 80, 70)
    assert det.kind == "object"
    assert det.label == "red mug"
    assert det.score == 0.8
    assert det.extra == {"prompt": "crop_box"}
    assert det.point is not None
    assert det.mask[det.point[1], det.point[0]]


async def test_an_implausible_crop_mask_falls_back_to_the_full_image_box() -> None:
    def masks(image: Any, prompt: SegmentPrompt) -> np.ndarray:
        if image.shape[:2] != (120, 160):
            return np.zeros(image.shape[:2], bool)  # the crop answer is empty
        return FakeSegmenter()._mask(image, prompt)

    seg = FakeSegmenter(masks)
    result = await run_skill(FIND, IMAGE, ctx(FakeGrounder(GroundingResult(targets=[MUG])), seg))
    assert [(c.method, c.image_shape) for c in seg.calls] == [
        ("box", (52, 52, 3)),
        ("box", (120, 160, 3)),
    ]
    assert seg.calls[1].prompt == MUG.box
    [det] = result.detections
    assert det.extra == {"prompt": "full_box", "mask_rejections": ["crop_box:empty"]}


async def test_when_both_box_prompts_leak_the_point_prompt_is_used() -> None:
    def masks(image: Any, prompt: SegmentPrompt) -> np.ndarray:
        if prompt.box is not None:
            out = np.zeros(image.shape[:2], bool)
            out[:, :] = True
            out[0, 0] = False
            return out  # covers the whole image: background
        return FakeSegmenter(point_radius_px=5)._mask(image, prompt)

    seg = FakeSegmenter(masks)
    result = await run_skill(FIND, IMAGE, ctx(FakeGrounder(GroundingResult(targets=[MUG])), seg))
    assert [c.method for c in seg.calls] == ["box", "box", "points"]
    assert seg.calls[2].prompt == [(60, 50)]
    [det] = result.detections
    assert det.extra["prompt"] == "points"
    assert det.mask is not None
    assert det.mask.sum() == 121


async def test_a_mask_leaking_far_outside_the_box_is_rejected() -> None:
    def leak(image: Any, prompt: SegmentPrompt) -> np.ndarray:
        out = np.zeros(image.shape[:2], bool)
        out[:, : image.shape[1] // 2 + 30] = True  # half the image: mostly outside the box
        return out

    result = await run_skill(
        FIND, IMAGE, ctx(FakeGrounder(GroundingResult(targets=[MUG])), FakeSegmenter(leak))
    )
    [det] = result.detections
    assert det.mask is None
    assert det.extra["mask_rejections"] == [
        "crop_box:covers_crop",
        "full_box:leaks_outside_box",
        "points:leaks_outside_box",
    ]


async def test_when_every_prompt_fails_the_detection_keeps_box_and_point_without_mask() -> None:
    seg = FakeSegmenter(empty)
    result = await run_skill(FIND, IMAGE, ctx(FakeGrounder(GroundingResult(targets=[MUG])), seg))
    [det] = result.detections
    assert det.mask is None
    assert det.box == MUG.box
    assert det.point == (60, 50)
    assert det.extra == {
        "mask_failed": True,
        "mask_rejections": ["crop_box:empty", "full_box:empty", "points:empty"],
    }


async def test_a_tiny_mask_is_implausible() -> None:
    def speck(image: Any, prompt: SegmentPrompt) -> np.ndarray:
        out = np.zeros(image.shape[:2], bool)
        out[50:54, 60:64] = True
        return out

    result = await run_skill(
        FIND,
        IMAGE,
        ctx(
            FakeGrounder(GroundingResult(targets=[MUG])),
            FakeSegmenter(speck),
            min_mask_fraction=0.05,
        ),
    )
    assert result.detections[0].extra["mask_rejections"][-1] == "points:too_small"


async def test_segmenter_errors_fall_back_instead_of_failing_the_skill() -> None:
    class Flaky(FakeSegmenter):
        def segment_box(self, image: Any, box: Any) -> np.ndarray:
            super().segment_box(image, box)
            raise ModelError("gpu out of memory")

    seg = Flaky()
    result = await run_skill(FIND, IMAGE, ctx(FakeGrounder(GroundingResult(targets=[MUG])), seg))
    [det] = result.detections
    assert det.extra["prompt"] == "points"
    assert det.extra["mask_rejections"] == ["crop_box:error", "full_box:error"]


async def test_a_target_with_only_points_is_segmented_from_the_points() -> None:
    target = GroundedTarget("mug", None, [(60, 50)])
    seg = FakeSegmenter(point_radius_px=3)
    result = await run_skill(FIND, IMAGE, ctx(FakeGrounder(GroundingResult(targets=[target])), seg))
    assert [c.method for c in seg.calls] == ["points"]
    [det] = result.detections
    assert det.box == (57, 47, 64, 54)  # from the mask
    assert det.score == 1.0


async def test_a_box_outside_the_image_is_ignored_and_points_are_used() -> None:
    target = GroundedTarget("mug", (500, 500, 600, 600), [(10, 10)])
    seg = FakeSegmenter()
    await run_skill(FIND, IMAGE, ctx(FakeGrounder(GroundingResult(targets=[target])), seg))
    assert [c.method for c in seg.calls] == ["points"]


async def test_ground_and_segment_without_segment_flag_never_calls_the_segmenter() -> None:
    seg = FakeSegmenter()
    skill = Skill("find", "ground_and_segment", grounding="mug", segment=False)
    result = await run_skill(skill, IMAGE, ctx(FakeGrounder(GroundingResult(targets=[MUG])), seg))
    assert seg.calls == []
    [det] = result.detections
    assert det.mask is None
    assert det.box == MUG.box
    assert det.point == (60, 50)
    assert det.extra == {}


async def test_ground_and_segment_publishes_typed_semantic_outputs_and_the_grounding() -> None:
    grounding = GroundingResult("yes", targets=[MUG], outputs={"found": "yes", "extra": 1})
    grounder = FakeGrounder(grounding)
    result = await run_skill(FIND, IMAGE, ctx(grounder))
    assert result.outputs == {"found": True}
    assert result.grounding is grounding
    [call] = grounder.calls
    assert call.question == "the red mug"
    assert call.mode == "ground_and_segment"
    assert [o.name for o in call.outputs] == ["found"]
    assert set(result.timings_ms) == {"ground", "segment"}


async def test_every_model_call_is_logged_with_stage_skill_cost_class_and_duration() -> None:
    with structlog.testing.capture_logs() as logs:
        await run_skill(FIND, IMAGE, ctx(FakeGrounder(GroundingResult(targets=[MUG]))))
    calls = [e for e in logs if e["event"] == "model_call"]
    assert [(e["stage"], e["skill"], e["cost_class"]) for e in calls] == [
        ("ground", "find", "cloud"),
        ("segment", "find", "local"),
    ]
    assert all(e["duration_ms"] >= 0 for e in calls)


async def test_reuse_grounding_skips_the_grounder_and_segments_the_new_frame() -> None:
    grounder = FakeGrounder(error=AssertionError("must not be called"))
    seg = NullSegmenter()
    cached = GroundingResult("cached", targets=[MUG], outputs={"found": True})
    result = await run_skill(FIND, IMAGE, ctx(grounder, seg), reuse_grounding=cached)
    assert grounder.calls == []
    assert result.grounding is cached
    assert result.detections[0].mask is not None
    assert "ground" not in result.timings_ms


async def test_grounder_errors_and_timeouts_reach_the_node_as_model_errors() -> None:
    with pytest.raises(ModelError, match="quota"):
        await run_skill(FIND, IMAGE, ctx(FakeGrounder(error=ModelError("quota"))))
    with pytest.raises(ModelError, match="timed out"):
        await run_skill(FIND, IMAGE, ctx(FakeGrounder(error=TimeoutError())))


async def test_describe_returns_semantic_outputs_only() -> None:
    grounding = GroundingResult(
        "a mug", targets=[MUG], outputs={"scene": "a mug on a table", "count": "2"}
    )
    grounder, seg = FakeGrounder(grounding), FakeSegmenter()
    skill = Skill(
        "scene",
        "describe",
        grounding="describe the table",
        segment=True,
        outputs=(SkillOutput("scene", "text"), SkillOutput("count", "number")),
    )
    result = await run_skill(skill, IMAGE, ctx(grounder, seg))
    assert result.detections == []
    assert result.outputs == {"scene": "a mug on a table", "count": 2}
    assert seg.calls == []
    assert grounder.calls[0].mode == "describe"


async def test_describe_with_reuse_grounding_returns_its_outputs_without_a_call() -> None:
    skill = Skill("scene", "describe", outputs=(SkillOutput("scene", "text"),))
    grounder = FakeGrounder(error=AssertionError("must not be called"))
    result = await run_skill(
        skill, IMAGE, ctx(grounder), GroundingResult(outputs={"scene": "cached"})
    )
    assert result.outputs == {"scene": "cached"}
    assert grounder.calls == []


async def test_missing_or_untypable_outputs_are_left_out_and_logged() -> None:
    skill = Skill(
        "scene", "describe", outputs=(SkillOutput("n", "number"), SkillOutput("t", "text"))
    )
    with structlog.testing.capture_logs() as logs:
        result = await run_skill(
            skill, IMAGE, ctx(FakeGrounder(GroundingResult(outputs={"n": "many"})))
        )
    assert result.outputs == {}
    events = {e["event"] for e in logs}
    assert {"semantic_output_invalid", "semantic_output_missing"} <= events


async def test_region_passes_the_free_space_rectangle_through_without_segmenting() -> None:
    space = GroundedTarget(
        "free space", (10, 20, 90, 100), [(50, 60)], kind="region", confidence=0.7
    )
    seg = FakeSegmenter()
    skill = Skill("place", "region", grounding="free space for the package", segment=True)
    grounder = FakeGrounder(GroundingResult(targets=[space]))
    result = await run_skill(skill, IMAGE, ctx(grounder, seg))
    assert seg.calls == []
    assert grounder.calls[0].mode == "region"
    [det] = result.detections
    assert (det.kind, det.box, det.mask, det.point, det.label, det.score) == (
        "region",
        (10, 20, 90, 100),
        None,
        (50, 60),
        "free space",
        0.7,
    )


async def test_a_region_without_an_anchor_is_anchored_at_its_centre_and_bad_ones_are_dropped() -> (
    None
):
    targets = [GroundedTarget("space", (0, 0, 40, 20), []), GroundedTarget("nowhere", None, [])]
    skill = Skill("place", "region", grounding="space")
    result = await run_skill(skill, IMAGE, ctx(FakeGrounder(GroundingResult(targets=targets))))
    assert [(d.label, d.point) for d in result.detections] == [("space", (20, 10))]


async def test_the_router_refuses_unknown_modes_and_bad_images() -> None:
    bad = Skill("x", "teleport", grounding="x")  # type: ignore[arg-type]
    with pytest.raises(SkillModeError, match="unknown mode"):
        await run_skill(bad, IMAGE, ctx(FakeGrounder()))
    with pytest.raises(ValueError, match="RGB"):
        await run_skill(FIND, np.zeros((10, 10), np.uint8), ctx(FakeGrounder()))
