"""Types shared by the pipelines and the node (the contract between them).

The node decides *whether* a skill runs this tick (rate, cost policy, gates); a pipeline
decides *how* (which model calls, in which order) and returns a :class:`SkillResult`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from robot_mcp_perception.models.base import (
    Box,
    Grounder,
    GroundingResult,
    Mask,
    Point,
    Segmenter,
    TargetKind,
)


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
