"""The reason pipeline: describe, ground_and_segment and region (spec 000 §5).

* describe — one grounder call; semantic outputs only, never detections.
* ground_and_segment — one grounder call → targets (box/points) → per target the mask
  fallback chain of :mod:`.segmentation` (when the skill has ``segment: true``).
* region — one grounder call in region mode → ``kind: "region"`` detections: box = the
  free-space rectangle, no mask, point = the anchor (the target's point, else box centre).

With ``reuse_grounding`` no grounder call is made: describe returns its outputs, the
others run only the local stages on the new frame.
"""

from __future__ import annotations

import structlog

from robot_mcp_perception.models.base import GroundingResult, Image
from robot_mcp_perception.pipelines.common import (
    Detection,
    PipelineContext,
    SkillResult,
    call_grounder,
)
from robot_mcp_perception.pipelines.segmentation import (
    object_detection,
    prompt_points,
    sanitize_box,
    segment_target,
)
from robot_mcp_perception.prompt_builder import coerce_outputs, semantic_requests
from robot_mcp_perception.skills import Skill

log = structlog.get_logger(__name__)


def question_of(skill: Skill) -> str:
    return skill.grounding or skill.description or skill.name.replace("_", " ")


async def ground(
    skill: Skill, image: Image, ctx: PipelineContext, timings: dict[str, float]
) -> GroundingResult:
    """The skill's single grounder call (grounding question + its semantic outputs)."""
    requests = semantic_requests(skill.outputs)
    return await call_grounder(
        "ground",
        skill.name,
        ctx.grounder,
        timings,
        ctx.grounder.ground(image, question_of(skill), requests, skill.mode),
    )


def typed_outputs(skill: Skill, grounding: GroundingResult) -> dict[str, object]:
    requests = semantic_requests(skill.outputs)
    outputs = coerce_outputs(grounding.outputs, requests)
    missing = [r.name for r in requests if r.name not in outputs]
    if missing:
        log.warning("semantic_output_missing", skill=skill.name, outputs=missing)
    return outputs


async def describe(
    skill: Skill, image: Image, ctx: PipelineContext, reuse: GroundingResult | None = None
) -> SkillResult:
    timings: dict[str, float] = {}
    grounding = reuse if reuse is not None else await ground(skill, image, ctx, timings)
    return SkillResult([], typed_outputs(skill, grounding), grounding, timings)


async def ground_and_segment(
    skill: Skill, image: Image, ctx: PipelineContext, reuse: GroundingResult | None = None
) -> SkillResult:
    timings: dict[str, float] = {}
    grounding = reuse if reuse is not None else await ground(skill, image, ctx, timings)
    shape = (image.shape[0], image.shape[1])
    detections = []
    for target in grounding.targets:
        if target.kind != "object":
            continue
        outcome = None
        if skill.segment:
            outcome = await segment_target(image, target, ctx, skill.name, timings)
        detections.append(object_detection(target, outcome, shape))
    return SkillResult(detections, typed_outputs(skill, grounding), grounding, timings)


async def region(
    skill: Skill, image: Image, ctx: PipelineContext, reuse: GroundingResult | None = None
) -> SkillResult:
    timings: dict[str, float] = {}
    grounding = reuse if reuse is not None else await ground(skill, image, ctx, timings)
    height, width = image.shape[:2]
    detections = []
    for target in grounding.targets:
        box = sanitize_box(target.box, width, height)
        points = prompt_points(target, box, width, height)
        if box is None and not points:
            log.warning("region_target_unusable", skill=skill.name, target=target.label)
            continue
        detections.append(
            Detection(
                label=target.label,
                score=float(target.confidence if target.confidence is not None else 1.0),
                kind="region",
                box=box,
                mask=None,
                point=points[0],
            )
        )
    return SkillResult(detections, typed_outputs(skill, grounding), grounding, timings)
