"""The tiled pipeline: segment_all (spec 000 §5).

1. The frame is cut into ``tile_grid`` tiles (with ``tile_overlap``); the grounder points at
   every instance in each tile (``Grounder.point``, tiles concurrently).
2. Answers are mapped tile → full image; pieces of one object cut by tile borders are merged
   (:func:`~.tiling.merge_truncated`), points closer than ``dedupe_radius_px`` are
   de-duplicated, then confidence NMS on boxes (``nms_iou``).
3. The segmenter runs once, on the full image, with one prompt per instance
   (``Segmenter.segment_many``). Masks that fail the plausibility check get one retry with
   their instances' point prompts, all in one more ``segment_many`` call on the full image;
   still implausible → the detection has no mask (``extra["mask_failed"]``).

One detection per instance. The merged targets are returned as the ``grounding`` (full-image
pixels), so with ``reuse_grounding`` only step 3 runs on the new frame. Declared semantic
outputs cost one extra ``ground`` call (mode ``segment_all``), sent together with the tile
requests (one round trip, so a run takes one grounder time limit, not two).
"""

from __future__ import annotations

import asyncio
from typing import Any

import numpy as np
import structlog

from robot_mcp_perception.models.base import (
    GroundedTarget,
    GroundingResult,
    Image,
    ModelError,
    SegmentPrompt,
)
from robot_mcp_perception.pipelines.common import (
    PipelineContext,
    SkillResult,
    call_grounder,
    call_segmenter,
)
from robot_mcp_perception.pipelines.reason import ground, typed_outputs
from robot_mcp_perception.pipelines.segmentation import (
    MaskOutcome,
    accept,
    object_detection,
    prompt_points,
    sanitize_box,
)
from robot_mcp_perception.pipelines.tiling import (
    dedupe_points,
    make_tiles,
    merge_truncated,
    nms,
    to_full_image,
)
from robot_mcp_perception.skills import Skill

log = structlog.get_logger(__name__)


async def point_tiles(
    skill: Skill, image: Image, ctx: PipelineContext, timings: dict[str, float]
) -> list[GroundedTarget]:
    """Per-tile pointing, mapped to the full image, merged, de-duplicated and NMS-ed."""
    height, width = image.shape[:2]
    settings = ctx.settings
    tiles = make_tiles(width, height, settings.tile_grid, settings.tile_overlap)
    query = skill.grounding or settings.segment_all_query

    async def one(tile_box: tuple[int, int, int, int]) -> list[GroundedTarget]:
        x0, y0, x1, y1 = tile_box
        crop = np.ascontiguousarray(image[y0:y1, x0:x1])
        return await call_grounder(
            "point", skill.name, ctx.grounder, timings, ctx.grounder.point(crop, query)
        )

    answers = await asyncio.gather(*(one(t.box) for t in tiles))
    mapped = [
        to_full_image(target, i, tiles[i], width, height)
        for i, targets in enumerate(answers)
        for target in targets
    ]
    merged = merge_truncated(mapped)
    kept = nms(dedupe_points(merged, settings.dedupe_radius_px), settings.nms_iou)
    return [m.target for m in kept]


async def segment_all(
    skill: Skill, image: Image, ctx: PipelineContext, reuse: GroundingResult | None = None
) -> SkillResult:
    timings: dict[str, float] = {}
    if reuse is not None:
        grounding = reuse
    else:
        if skill.outputs:
            targets, answered = await asyncio.gather(
                point_tiles(skill, image, ctx, timings), ground(skill, image, ctx, timings)
            )
            outputs = answered.outputs
        else:
            targets, outputs = await point_tiles(skill, image, ctx, timings), {}
        answer = f"{len(targets)} instance(s)"
        grounding = GroundingResult(answer, "tiled pointing", targets, outputs)
    shape = (image.shape[0], image.shape[1])
    targets = [t for t in grounding.targets if t.kind == "object"]
    outcomes: list[MaskOutcome | None] = [None] * len(targets)
    if skill.segment and targets:
        outcomes = list(await segment_instances(skill, image, ctx, targets, timings))
    detections = [object_detection(t, o, shape) for t, o in zip(targets, outcomes, strict=True)]
    return SkillResult(detections, typed_outputs(skill, grounding), grounding, timings)


async def segment_instances(
    skill: Skill,
    image: Image,
    ctx: PipelineContext,
    targets: list[GroundedTarget],
    timings: dict[str, float],
) -> list[MaskOutcome]:
    """One segmenter call on the full image for every instance (+ point retry for rejects)."""
    height, width = image.shape[:2]
    boxes = [sanitize_box(t.box, width, height) for t in targets]
    points = [prompt_points(t, b, width, height) for t, b in zip(targets, boxes, strict=True)]
    prompts = [SegmentPrompt(b, p) for b, p in zip(boxes, points, strict=True)]
    usable = [i for i, p in enumerate(prompts) if p.box is not None or p.points]
    outcomes = [MaskOutcome(None, rejections=["no_prompt"]) for _ in targets]
    if not usable:
        return outcomes
    seg = ctx.segmenter
    try:
        masks: list[Any] = await call_segmenter(
            "segment",
            skill.name,
            seg,
            timings,
            seg.segment_many,
            image,
            [prompts[i] for i in usable],
        )
    except (ModelError, ValueError) as exc:
        log.warning("segment_batch_failed", skill=skill.name, error=str(exc))
        masks = [None] * len(usable)
    if len(masks) != len(usable):
        log.warning(
            "segment_batch_size_mismatch", skill=skill.name, prompts=len(usable), masks=len(masks)
        )
        masks = [*masks, *[None] * len(usable)][: len(usable)]
    for i, raw in zip(usable, masks, strict=True):
        mask, reason = accept(raw, boxes[i], points[i], ctx.settings, (height, width))
        outcomes[i] = MaskOutcome(mask, "batch", [] if reason is None else [f"batch:{reason}"])
    retry = [i for i in usable if outcomes[i].mask is None and points[i] and boxes[i] is not None]
    if not retry:
        return outcomes
    try:  # every retry of this frame in one call: the image is embedded once
        retried: list[Any] = await call_segmenter(
            "segment",
            skill.name,
            seg,
            timings,
            seg.segment_many,
            image,
            [SegmentPrompt(None, points[i]) for i in retry],
        )
    except (ModelError, ValueError) as exc:
        log.warning("segment_attempt_failed", skill=skill.name, prompt="points", error=str(exc))
        for i in retry:
            outcomes[i].rejections.append("points:error")
        return outcomes
    retried = [*retried, *[None] * len(retry)][: len(retry)]
    for i, raw in zip(retry, retried, strict=True):
        mask, reason = accept(raw, boxes[i], points[i], ctx.settings, (height, width))
        if mask is not None:
            outcomes[i].mask, outcomes[i].prompt = mask, "points"
        else:
            outcomes[i].rejections.append(f"points:{reason}")
    return outcomes
