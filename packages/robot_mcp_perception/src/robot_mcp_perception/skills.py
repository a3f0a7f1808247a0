"""Skill = the unit of configuration of the vision node (spec 000 §3, ARCHITECTURE §4.1).

Validation and JSON (de)serialisation are added by the node-runtime work; the field set
below is the contract the pipelines rely on.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

SkillMode = Literal["describe", "ground_and_segment", "segment_all", "region"]
OutputType = Literal["text", "number", "boolean", "list", "position", "pose"]


@dataclass(frozen=True)
class SkillOutput:
    name: str
    type: OutputType
    description: str = ""


@dataclass(frozen=True)
class WatchSpec:
    output: str
    equals: object = True


@dataclass(frozen=True)
class Skill:
    name: str
    mode: SkillMode
    description: str = ""
    grounding: str = ""
    segment: bool = False
    outputs: tuple[SkillOutput, ...] = field(default_factory=tuple)
    rate_hz: float | None = None
    """None = the node's processing_frequency."""
    once: bool = False
    watch: WatchSpec | None = None
    prewarm: bool = False
