"""Types shared by the pipelines and the node (the contract between them).

The node decides *whether* a skill runs this tick (rate, cost policy, gates); a pipeline
decides *how* (which model calls, in which order) and returns a :class:`SkillResult`.
"""

from __future__ import annotations

import asyncio
import time
from collections.abc import Callable, Coroutine, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any, TypeVar

import structlog

from robot_mcp_perception.models.answers import Answer, note
from robot_mcp_perception.models.base import (
    Box,
    CostClass,
    Grounder,
    GroundingResult,
    Mask,
    ModelError,
    Point,
    Segmenter,
    TargetKind,
)
from robot_mcp_perception.models.metering import charge_cloud_request

log = structlog.get_logger("robot_mcp_perception.pipelines")
T = TypeVar("T")


@dataclass(frozen=True)
class PipelineSettings:
    """Pipeline knobs from the Hydra ``pipeline`` block (spec 000 §4/§5)."""

    crop_margin: float = 0.15
    """Fraction of the box size added on each side when cropping for the box prompt."""
    tile_grid: tuple[int, int] = (2, 2)
    """(columns, rows) of tiles for segment_all pointing."""
    tile_overlap: float = 0.1
    dedupe_radius_px: int = 12
    nms_iou: float = 0.5
    min_mask_fraction: float = 0.0005
    """Plausibility: masks smaller than this fraction of the box are rejected."""
    max_mask_fraction: float = 0.9
    """Plausibility / background filter: masks covering more of the image are rejected."""
    max_outside_box_fraction: float = 0.5
    """Plausibility: a mask with more of its pixels outside the prompt box leaks to background."""
    speck_fraction: float = 0.0005
    """Post-processing: mask components smaller than this fraction of the image are specks."""
    segment_all_query: str = "every distinct object"
    """Pointing query of a segment_all skill that has no ``grounding`` text."""


@dataclass
class PipelineContext:
    grounder: Grounder
    segmenter: Segmenter
    settings: PipelineSettings = field(default_factory=PipelineSettings)


@dataclass
class Detection:
    label: str
    score: float
    kind: TargetKind
    box: Box | None
    mask: Mask | None
    """Full-frame boolean mask; None for regions and describe results."""
    point: Point | None
    extra: dict[str, Any] = field(default_factory=dict)


@dataclass
class SkillResult:
    detections: list[Detection] = field(default_factory=list)
    outputs: dict[str, Any] = field(default_factory=dict)
    """Semantic outputs by name, typed per the skill's declared output types."""
    grounding: GroundingResult | None = None
    """What the grounder said; the node caches it (prewarm, ground-once-segment-at-rate)."""
    timings_ms: dict[str, float] = field(default_factory=dict)
    """duration per stage, e.g. {"ground": 812.0, "segment": 21.4}."""
    grounded_by: dict[str, Any] = field(default_factory=dict)
    """Who answered the run's grounder calls (:func:`..models.answers.marks`), set by the
    engine; empty when no grounder was called (a re-used grounding keeps its own)."""


class SkillModeError(ValueError):
    """The skill cannot run (unknown mode, missing watched output, …) — a configuration error."""


@contextmanager
def model_call(
    stage: str, skill: str, cost_class: CostClass, timings: dict[str, float]
) -> Iterator[None]:
    """Time one model call: log ``model_call`` {stage, skill, cost_class, duration_ms} and add
    the duration to ``timings[stage]`` (also when the call fails)."""
    started = time.perf_counter()
    ok = False
    try:
        yield
        ok = True
    finally:
        duration_ms = round(1000 * (time.perf_counter() - started), 2)
        timings[stage] = round(timings.get(stage, 0.0) + duration_ms, 2)
        log.info(
            "model_call",
            stage=stage,
            skill=skill,
            cost_class=cost_class,
            duration_ms=duration_ms,
            ok=ok,
        )


async def call_grounder(
    stage: str,
    skill: str,
    grounder: Grounder,
    timings: dict[str, float],
    call: Coroutine[Any, Any, T],
) -> T:
    """Await a grounder call under :func:`model_call`.

    Grounder failures reach the node as :class:`ModelError` (it republishes the stale
    result): ModelError passes through, a timeout becomes ModelError. A cloud grounder's
    request is charged to the run's meter first (refused: CloudBudgetExhaustedError), and
    who answered is noted (:mod:`..models.answers`) — a composite grounder (the fallback
    chain) does both itself.
    """
    if grounder.cost_class == "cloud" and not grounder.composite:
        try:
            charge_cloud_request(f"{stage} request of skill {skill!r}")
        except ModelError:
            call.close()  # never awaited
            raise
    with model_call(stage, skill, grounder.cost_class, timings):
        try:
            answer = await call
        except TimeoutError as exc:
            raise ModelError(f"{stage} call of skill {skill!r} timed out", "timeout") from exc
    if not grounder.composite:
        note(Answer(grounder.name or type(grounder).__name__))
    return answer


async def call_segmenter(
    stage: str,
    skill: str,
    segmenter: Segmenter,
    timings: dict[str, float],
    fn: Callable[..., T],
    *args: Any,
) -> T:
    """Run a (synchronous, possibly slow) segmenter call in a worker thread, timed (a cloud
    segmenter's request is charged to the run's meter first)."""
    if segmenter.cost_class == "cloud":
        charge_cloud_request(f"{stage} request of skill {skill!r}")
    with model_call(stage, skill, segmenter.cost_class, timings):
        return await asyncio.to_thread(fn, *args)
