"""Pipelines and the router (spec 000 §5): one pipeline per skill mode.

==================  ==================  =============================================
mode                pipeline            result
==================  ==================  =============================================
describe            reason (no seg)     semantic outputs only
ground_and_segment  reason (object)     detections (box, point, mask) + outputs
region              reason (region)     ``kind="region"`` detections (box, anchor)
segment_all         tiled               one detection per instance
==================  ==================  =============================================

A watcher skill (``watch`` block) runs its mode's pipeline; the router then makes its
watched output a boolean (:func:`.watch.watched_value`) — a run whose answer lacks it fails
like a bad model answer. The frame-difference gate (:class:`.watch.FrameDiffGate`) is applied
by the node before a run.

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
from robot_mcp_perception.pipelines.common import (
    PipelineContext,
    PipelineSettings,
    SkillModeError,
    SkillResult,
)
from robot_mcp_perception.pipelines.reason import describe, ground_and_segment, region
from robot_mcp_perception.pipelines.tiled import segment_all
from robot_mcp_perception.pipelines.watch import watched_value
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
    result = await pipeline(skill, image, ctx, reuse_grounding)
    if skill.watch is not None:
        result.outputs[skill.watch.output] = watched_value(skill, result)
    return result


def grounder_requests(skill: Skill, settings: PipelineSettings) -> int:
    """Grounder calls one fresh run of ``skill`` makes (the cloud budget reserves them all):
    segment_all points once per tile, plus one ``ground`` call for declared outputs."""
    if skill.mode != "segment_all":
        return 1
    cols, rows = settings.tile_grid
    return cols * rows + (1 if skill.outputs else 0)


__all__ = ["PIPELINES", "grounder_requests", "run_skill"]
