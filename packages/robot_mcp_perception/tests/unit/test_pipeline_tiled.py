"""Spec 000 §9 item 2 — segment_all: tile → full-image mapping, dedupe + NMS, the segmenter
once on the full image, one detection per instance."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from robot_mcp_perception.models.annotation import AnnotationGrounder
from robot_mcp_perception.models.base import (
    Box,
    GroundedTarget,
    GroundingResult,
    ModelError,
    SegmentPrompt,
)
from robot_mcp_perception.models.fakes import FakeGrounder, FakeSegmenter
from robot_mcp_perception.models.grabcut import GrabCutSegmenter
from robot_mcp_perception.pipelines import run_skill
from robot_mcp_perception.pipelines.common import PipelineContext, PipelineSettings
from robot_mcp_perception.pipelines.tiling import (
    MappedTarget,
    Tile,
    box_iou,
    dedupe_points,
    make_tiles,
    merge_truncated,
    nms,
    to_full_image,
)
from robot_mcp_perception.postprocess import mask_iou
from robot_mcp_perception.sample_scenes import generate_scenes, polygon_mask, render_scene
from robot_mcp_perception.skills import Skill, SkillOutput

SEGMENT_ALL = Skill("everything", "segment_all", segment=True)


def coded_image(width: int = 160, height: int = 120) -> np.ndarray:
    """Each pixel carries its own (x, y): a fake pointer can tell where a tile came from."""
    image = np.zeros((height, width, 3), np.uint8)
    image[:, :, 0] = np.arange(width, dtype=np.uint8)[None, :]
    image[:, :, 1] = np.arange(height, dtype=np.uint8)[:, None]
    return image


class WorldPointer:
    """Points at the visible part of each world box in the tile it is shown (like a VLM)."""

    def __init__(self, objects: list[tuple[str, Box]]) -> None:
        self.objects = objects

    def __call__(self, image: Any, question: str, mode: str) -> GroundingResult:
        x0, y0 = int(image[0, 0, 0]), int(image[0, 0, 1])
        h, w = image.shape[:2]
        targets = []
        for label, (bx0, by0, bx1, by1) in self.objects:
            vx0, vy0 = max(bx0, x0), max(by0, y0)
            vx1, vy1 = min(bx1, x0 + w), min(by1, y0 + h)
            if vx1 <= vx0 or vy1 <= vy0:
                continue
            fraction = (vx1 - vx0) * (vy1 - vy0) / ((bx1 - bx0) * (by1 - by0))
            box = (vx0 - x0, vy0 - y0, vx1 - x0, vy1 - y0)
            point = ((box[0] + box[2]) // 2, (box[1] + box[3]) // 2)
            targets.append(GroundedTarget(label, box, [point], confidence=round(fraction, 3)))
        return GroundingResult(targets=targets)


def ctx(grounder: Any, segmenter: Any = None, **settings: Any) -> PipelineContext:
    return PipelineContext(grounder, segmenter or FakeSegmenter(), PipelineSettings(**settings))


async def test_each_instance_yields_one_detection_with_its_full_image_box() -> None:
    world = [
        ("cup", (5, 5, 30, 30)),  # inside the top-left tile only
        ("box", (74, 10, 86, 30)),  # inside the vertical overlap: seen whole by two tiles
        ("plate", (60, 45, 110, 80)),  # across the centre: cut into four pieces
        ("pen", (120, 90, 150, 110)),  # bottom-right tile only
    ]
    grounder = FakeGrounder(WorldPointer(world))
    seg = FakeSegmenter()
    result = await run_skill(SEGMENT_ALL, coded_image(), ctx(grounder, seg))
    assert grounder.point_calls == 4
    assert grounder.ground_calls == 0
    assert sorted((d.label, d.box) for d in result.detections) == sorted(world)
    assert all(d.mask is not None and d.mask.shape == (120, 160) for d in result.detections)
    assert len({d.label for d in result.detections}) == len(result.detections)


async def test_the_segmenter_runs_once_on_the_full_image_with_one_prompt_per_instance() -> None:
    world = [("cup", (5, 5, 30, 30)), ("plate", (60, 45, 110, 80))]
    seg = FakeSegmenter()
    await run_skill(SEGMENT_ALL, coded_image(), ctx(FakeGrounder(WorldPointer(world)), seg))
    [call] = seg.calls
    assert call.method == "many"
    assert call.image_shape == (120, 160, 3)
    assert sorted(p.box for p in call.prompt) == sorted(b for _, b in world)


async def test_tiles_are_sent_to_the_grounder_as_crops_with_the_pointing_query() -> None:
    grounder = FakeGrounder(WorldPointer([]))
    skill = Skill("all_mugs", "segment_all", grounding="every mug", segment=True)
    result = await run_skill(
        skill, coded_image(), ctx(grounder, tile_grid=(3, 2), tile_overlap=0.0)
    )
    assert [c.image_shape for c in grounder.calls] == [(60, 53, 3), (60, 54, 3), (60, 53, 3)] * 2
    assert {c.question for c in grounder.calls} == {"every mug"}
    assert result.detections == []


async def test_the_default_query_points_at_every_object() -> None:
    grounder = FakeGrounder(WorldPointer([]))
    await run_skill(SEGMENT_ALL, coded_image(), ctx(grounder))
    assert {c.question for c in grounder.calls} == {"every distinct object"}


async def test_reuse_grounding_segments_the_cached_instances_without_pointing() -> None:
    grounder = FakeGrounder(WorldPointer([("cup", (5, 5, 30, 30))]))
    first = await run_skill(SEGMENT_ALL, coded_image(), ctx(grounder))
    assert first.grounding is not None
    again = FakeGrounder(error=AssertionError("must not be called"))
    seg = FakeSegmenter()
    second = await run_skill(SEGMENT_ALL, coded_image(), ctx(again, seg), first.grounding)
    assert again.calls == []
    assert seg.call_count == 1
    assert [(d.label, d.box) for d in second.detections] == [("cup", (5, 5, 30, 30))]


async def test_semantic_outputs_of_segment_all_cost_one_ground_call() -> None:
    def answer(image: Any, question: str, mode: str) -> GroundingResult:
        if mode == "point":
            return WorldPointer([("cup", (5, 5, 30, 30))])(image, question, mode)
        return GroundingResult(outputs={"count": 1})

    grounder = FakeGrounder(answer)
    skill = Skill("all", "segment_all", segment=True, outputs=(SkillOutput("count", "number"),))
    result = await run_skill(skill, coded_image(), ctx(grounder))
    assert grounder.ground_calls == 1
    assert [c.mode for c in grounder.calls if c.method == "ground"] == ["segment_all"]
    assert result.outputs == {"count": 1}


async def test_without_segment_flag_instances_have_no_masks() -> None:
    seg = FakeSegmenter()
    skill = Skill("all", "segment_all", segment=False)
    result = await run_skill(
        skill, coded_image(), ctx(FakeGrounder(WorldPointer([("cup", (5, 5, 30, 30))])), seg)
    )
    assert seg.calls == []
    assert [(d.box, d.mask) for d in result.detections] == [((5, 5, 30, 30), None)]


async def test_a_rejected_batch_mask_is_retried_with_the_point_prompt() -> None:
    def masks(image: Any, prompt: SegmentPrompt) -> np.ndarray:
        out = np.zeros(image.shape[:2], bool)
        if prompt.box is None:
            x, y = prompt.points[0]
            out[y - 3 : y + 4, x - 3 : x + 4] = True
        return out

    seg = FakeSegmenter(masks)
    result = await run_skill(
        SEGMENT_ALL, coded_image(), ctx(FakeGrounder(WorldPointer([("cup", (5, 5, 30, 30))])), seg)
    )
    assert [c.method for c in seg.calls] == ["many", "many"]
    [det] = result.detections
    assert det.extra == {"prompt": "points", "mask_rejections": ["batch:empty"]}


async def test_the_point_retries_of_one_frame_go_to_the_segmenter_in_one_call() -> None:
    def masks(image: Any, prompt: SegmentPrompt) -> np.ndarray:
        out = np.zeros(image.shape[:2], bool)
        if prompt.box is None:
            x, y = prompt.points[0]
            out[y - 3 : y + 4, x - 3 : x + 4] = True
        return out

    seg = FakeSegmenter(masks)
    world = [("cup", (5, 5, 30, 30)), ("pen", (120, 90, 150, 110)), ("box", (60, 10, 90, 40))]
    result = await run_skill(
        SEGMENT_ALL, coded_image(), ctx(FakeGrounder(WorldPointer(world)), seg)
    )

    assert [c.method for c in seg.calls] == ["many", "many"]
    assert [p.box for p in seg.calls[1].prompt] == [None, None, None]
    assert all(d.extra.get("prompt") == "points" for d in result.detections)


async def test_segmenter_failures_in_segment_all_leave_detections_without_masks() -> None:
    class Broken(FakeSegmenter):
        def segment_many(self, image: Any, prompts: list[SegmentPrompt]) -> list[np.ndarray]:
            raise ModelError("cuda error")

        def segment_points(self, image: Any, points: Any) -> np.ndarray:
            raise ModelError("cuda error")

    result = await run_skill(
        SEGMENT_ALL,
        coded_image(),
        ctx(FakeGrounder(WorldPointer([("cup", (5, 5, 30, 30))])), Broken()),
    )
    [det] = result.detections
    assert det.mask is None
    assert det.box == (5, 5, 30, 30)
    assert det.extra == {
        "mask_failed": True,
        "mask_rejections": ["batch:bad_mask_shape:NoneType", "points:error"],
    }


async def test_a_segmenter_returning_too_few_masks_does_not_shift_instances() -> None:
    class Short(FakeSegmenter):
        def segment_many(self, image: Any, prompts: list[SegmentPrompt]) -> list[np.ndarray]:
            return super().segment_many(image, prompts)[:1]

    world = [("cup", (5, 5, 30, 30)), ("pen", (120, 90, 150, 110))]
    result = await run_skill(
        SEGMENT_ALL, coded_image(), ctx(FakeGrounder(WorldPointer(world)), Short())
    )
    masked = [d for d in result.detections if d.mask is not None]
    assert len(result.detections) == 2
    assert len(masked) == 2
    for d in masked:
        assert d.box is not None
        assert d.mask is not None
        assert d.mask[d.box[1] : d.box[3], d.box[0] : d.box[2]].any()


@pytest.fixture(scope="module")
def scene_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    directory = tmp_path_factory.mktemp("tiled_scenes")
    generate_scenes(directory, count=4, seed=0, size=(320, 240))
    return directory


async def test_segment_all_with_the_offline_grounder_and_grabcut_finds_every_object(
    scene_dir: Path,
) -> None:
    context = ctx(AnnotationGrounder(str(scene_dir)), GrabCutSegmenter())
    for index in range(4):
        image, doc = render_scene(index, seed=0, size=(320, 240))
        result = await run_skill(SEGMENT_ALL, image, context)
        assert len(result.detections) == len(doc["annotations"])
        for ann in doc["annotations"]:
            truth = polygon_mask(ann["segmentation"], 320, 240)
            best = max(mask_iou(d.mask, truth) for d in result.detections if d.mask is not None)
            assert best >= 0.5, (index, ann["label"])


def test_tiles_cover_the_image_with_the_requested_overlap() -> None:
    tiles = make_tiles(160, 120, (2, 2), 0.1)
    assert [t.box for t in tiles] == [
        (0, 0, 88, 66),
        (72, 0, 160, 66),
        (0, 54, 88, 120),
        (72, 54, 160, 120),
    ]
    assert tiles[0].interior_sides(160, 120) == {"right", "bottom"}
    assert make_tiles(10, 10, (1, 1), 0.0)[0].box == (0, 0, 10, 10)
    with pytest.raises(ValueError):
        make_tiles(10, 10, (0, 1), 0.1)
    with pytest.raises(ValueError):
        make_tiles(10, 10, (1, 1), 1.0)


def test_targets_are_mapped_from_tile_to_full_image_pixels() -> None:
    tile = Tile((72, 54, 160, 120))
    mapped = to_full_image(GroundedTarget("cup", (0, 10, 20, 30), [(5, 15)]), 3, tile, 160, 120)
    assert mapped.target.box == (72, 64, 92, 84)
    assert mapped.target.points == [(77, 69)]
    assert mapped.truncated == {"left"}  # cut by the tile's left side, which is interior
    pointed = to_full_image(GroundedTarget("cup", None, [(1, 2)]), 3, tile, 160, 120)
    assert pointed.target.box is None
    assert pointed.target.points == [(73, 56)]


def test_points_closer_than_the_radius_are_deduplicated_keeping_the_most_confident() -> None:
    a = MappedTarget(GroundedTarget("cup", None, [(10, 10)], confidence=0.5), 0)
    b = MappedTarget(GroundedTarget("mug", None, [(14, 13)], confidence=0.9), 1)
    c = MappedTarget(GroundedTarget("pen", None, [(40, 40)], confidence=0.7), 1)
    kept = dedupe_points([a, b, c], radius_px=6)
    assert [k.target.label for k in kept] == ["mug", "pen"]


def test_confidence_nms_drops_overlapping_boxes() -> None:
    a = MappedTarget(GroundedTarget("cup", (0, 0, 20, 20), [], confidence=0.6), 0)
    b = MappedTarget(GroundedTarget("cup", (2, 2, 22, 22), [], confidence=0.9), 1)
    c = MappedTarget(GroundedTarget("cup", (30, 30, 40, 40), [], confidence=0.1), 1)
    d = MappedTarget(GroundedTarget("dot", None, [(1, 1)]), 1)
    kept = nms([a, b, c, d], iou_threshold=0.5)
    assert [k.target.box for k in kept] == [None, (2, 2, 22, 22), (30, 30, 40, 40)]
    assert box_iou((0, 0, 10, 10), (20, 20, 30, 30)) == 0.0
    assert box_iou((0, 0, 0, 0), (0, 0, 0, 0)) == 0.0


def test_pieces_cut_by_tile_borders_are_merged_into_one_box() -> None:
    left = MappedTarget(
        GroundedTarget("plate", (60, 45, 88, 80), [(70, 60)], confidence=0.6),
        0,
        frozenset({"right"}),
    )
    right = MappedTarget(
        GroundedTarget("plate", (72, 45, 110, 80), [(90, 60)], confidence=0.8),
        1,
        frozenset({"left"}),
    )
    other = MappedTarget(GroundedTarget("cup", (80, 45, 100, 60), [(90, 50)]), 1)
    merged = merge_truncated([left, right, other])
    assert sorted((m.target.label, m.target.box) for m in merged) == [
        ("cup", (80, 45, 100, 60)),
        ("plate", (60, 45, 110, 80)),
    ]
    plate = next(m for m in merged if m.target.label == "plate")
    assert plate.target.points == [(90, 60)]
    assert plate.score == 0.8
