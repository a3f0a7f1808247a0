"""Skill registry: the live skills of the node, their topics and per-skill run state."""

from __future__ import annotations

import threading
from collections import Counter
from dataclasses import dataclass, field
from typing import Any, Protocol

from robot_mcp_perception.frames import Frame
from robot_mcp_perception.models.base import GroundingResult, Image
from robot_mcp_perception.pipelines.common import SkillResult
from robot_mcp_perception.provenance import FRESH, Provenance
from robot_mcp_perception.skills import Skill, SkillError


class Gate(Protocol):
    """The frame-difference watch gate (``pipelines.watch.FrameDiffGate``)."""

    def passes(self, image: Image) -> bool: ...

    def reset(self) -> None: ...


@dataclass(frozen=True)
class GroundingSource:
    """A grounding and the frame it was made on (its boxes are pixels of that frame)."""

    grounding: GroundingResult
    stamp_ns: int
    frame_id: str = ""
    grounded_by: dict[str, Any] = field(default_factory=dict)
    """Who answered it (``models.answers.marks``)."""


@dataclass(frozen=True)
class SkillTopics:
    detections: str
    detections_meta: str
    overlay: str
    outputs: dict[str, str]

    def as_dict(self) -> dict[str, Any]:
        return {
            "detections": self.detections,
            "detections_meta": self.detections_meta,
            "overlay": self.overlay,
            "outputs": dict(self.outputs),
        }

    def all(self) -> list[str]:
        return [self.detections, self.detections_meta, self.overlay, *self.outputs.values()]


def topics_for(namespace: str, skill: Skill) -> SkillTopics:
    base = f"{namespace.rstrip('/')}/{skill.name}"
    return SkillTopics(
        detections=f"{base}/detections",
        detections_meta=f"{base}/detections_meta",
        overlay=f"{base}/overlay",
        outputs={output.name: f"{base}/{output.name}" for output in skill.outputs},
    )


@dataclass
class SkillState:
    skill: Skill
    topics: SkillTopics
    enabled: bool = True
    gate: Gate | None = None
    always_gated: bool = False
    """ambient_scene: gated whatever the cost class."""
    publishers: Any = None
    """The node's per-skill publisher set (``publishers.SkillPublishers``)."""
    next_due: float = 0.0
    last_seq: int = -1
    in_flight: int = 0
    once_pending: bool = False
    runs: int = 0
    published: int = 0
    failures: int = 0
    consecutive_failures: int = 0
    last_error: str | None = None
    skips: Counter[str] = field(default_factory=Counter)
    last_result: SkillResult | None = None
    last_frame: Frame | None = None
    last_extras: list[dict[str, Any]] = field(default_factory=list)
    """Per-detection ``extra`` additions of the last fresh publish (its mask_refs)."""
    last_provenance: Provenance = FRESH
    """Markers of the last fresh publish (a stale republish adds its reason to them)."""
    last_published_stamp_ns: int = -1
    last_publish_wall: float | None = None
    grounding: GroundingSource | None = None
    """Latest grounding, reused while the gate says the scene is unchanged (segment at rate)."""

    def describe(self) -> dict[str, Any]:
        return {
            **self.skill.to_dict(),
            "enabled": self.enabled,
            "topics": self.topics.as_dict(),
            "runs": self.runs,
            "published": self.published,
        }


class SkillRegistry:
    """Thread-safe map name → :class:`SkillState`."""

    def __init__(self) -> None:
        self._skills: dict[str, SkillState] = {}
        self._lock = threading.RLock()

    def add(self, state: SkillState) -> None:
        with self._lock:
            if state.skill.name in self._skills:
                raise SkillError(
                    "duplicate_name",
                    f"a skill named {state.skill.name!r} already exists; delete it first or "
                    "pick another name.",
                )
            self._skills[state.skill.name] = state

    def get(self, name: str) -> SkillState:
        with self._lock:
            state = self._skills.get(name)
        if state is None:
            raise SkillError("unknown_skill", f"there is no skill named {name!r}.")
        return state

    def find(self, name: str) -> SkillState | None:
        with self._lock:
            return self._skills.get(name)

    def remove(self, name: str) -> SkillState:
        with self._lock:
            state = self.get(name)
            del self._skills[name]
            return state

    def states(self) -> list[SkillState]:
        with self._lock:
            return list(self._skills.values())

    def __contains__(self, name: object) -> bool:
        with self._lock:
            return name in self._skills

    def __len__(self) -> int:
        with self._lock:
            return len(self._skills)
