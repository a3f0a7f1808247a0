"""Pipelines and the router (spec 000 §5): one pipeline per skill mode.

==================  ==================  =============================================
mode                pipeline            result
==================  ==================  =============================================
describe            reason (no seg)     semantic outputs only
ground_and_segment  reason (object)     detections (box, point, mask) + outputs
region              reason (region)     ``kind="region"`` detections (box, anchor)
segment_all         tiled               one detection per instance
==================  ==================  =============================================

The watch pipeline (:mod:`.watch`) wraps any of these behind a frame-difference gate.

Errors: a grounder failure (error, timeout, unusable answer) propagates as
:class:`~robot_mcp_perception.models.base.ModelError` — the node republishes the last
result stamped stale. Segmenter failures never propagate: each falls back along the chain
of :mod:`.segmentation` and, if everything fails, the detection keeps its box and point with
``mask=None`` and ``extra["mask_failed"] = True`` (+ ``extra["mask_rejections"]``).
A skill the router cannot run raises :class:`~.common.SkillModeError`.
"""

from __future__ import annotations

from collections.abc import Awaitable, Callable

from robot_mcp_perception.models.base import GroundingResult, Image
from robot_mcp_perception.pipelines.common import PipelineContext, SkillModeError, SkillResult
from robot_mcp_perception.pipelines.reason import describe, ground_and_segment, region
from robot_mcp_perception.pipelines.tiled import segment_all
from robot_mcp_perception.skills import Skill

Pipeline = Callable[[Skill, Image, PipelineContext, GroundingResult | None], Awaitable[SkillResult]]

PIPELINES: dict[str, Pipeline] = {
    "describe": describe,
    "ground_and_segment": ground_and_segment,
    "region": region,
    "segment_all": segment_all,
}


async def run_skill(
    skill: Skill,
    image: Image,
    ctx: PipelineContext,
    reuse_grounding: GroundingResult | None = None,
) -> SkillResult:
    """Run one skill on one frame.

    With ``reuse_grounding`` (prewarm cache, "ground once, segment locally at rate") the
    grounder is not called: its targets are segmented on this frame (describe returns its
    outputs).
    """
    pipeline = PIPELINES.get(skill.mode)
    if pipeline is None:
        raise SkillModeError(f"skill {skill.name!r} has unknown mode {skill.mode!r}")
    if image.ndim != 3 or image.shape[2] != 3 or image.shape[0] == 0 or image.shape[1] == 0:
        raise ValueError(f"image must be RGB (H, W, 3), got shape {image.shape}")
    return await pipeline(skill, image, ctx, reuse_grounding)


__all__ = ["PIPELINES", "run_skill"]
