"""Model ports of the vision node (spec 000 §4).

A *grounder* decides what/where (labels, boxes, points, semantic answers); a *segmenter*
turns a box or point prompt into pixels. Adapters live beside this module; the node and the
pipelines import only these ports.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from typing import Any, Literal

# the pixel types live below the models: mask post-processing uses them too
from robot_mcp_perception.pixels import Box as Box
from robot_mcp_perception.pixels import Image as Image
from robot_mcp_perception.pixels import Mask as Mask
from robot_mcp_perception.pixels import Point as Point

CostClass = Literal["local", "cloud"]
TargetKind = Literal["object", "region"]


FailureKind = Literal[
    "network", "server_error", "quota", "timeout", "budget", "auth", "bad_answer", "error"
]
"""Why a model call failed. The first six say the model could not be reached or refused to
serve (a cloud outage, :data:`OUTAGES`); ``bad_answer`` is an answer that could not be used."""

OUTAGES: frozenset[str] = frozenset(
    ("network", "server_error", "quota", "timeout", "budget", "auth")
)
"""Failures a grounder chain answers with its fallback (``models.chain``)."""


class ModelError(Exception):
    """A model call failed in a way the caller should log and survive (retry, stale result).

    ``kind`` names the failure (:data:`FailureKind`); adapters set it where they know it."""

    def __init__(self, message: str = "", kind: FailureKind = "error") -> None:
        super().__init__(message)
        self.kind: FailureKind = kind


class ModelUnavailableError(ModelError):
    """A model cannot be used at all: missing key, missing weights, missing optional extra."""


@dataclass(frozen=True)
class GroundedTarget:
    label: str
    box: Box | None
    points: list[Point]
    kind: TargetKind = "object"
    confidence: float | None = None


@dataclass(frozen=True)
class SemanticRequest:
    """One semantic output a skill asks the grounder to answer alongside grounding."""

    name: str
    type: str
    description: str = ""


@dataclass(frozen=True)
class GroundingResult:
    answer: str = ""
    reasoning: str = ""
    targets: list[GroundedTarget] = field(default_factory=list)
    outputs: dict[str, Any] = field(default_factory=dict)
    """Semantic outputs by name, already coerced to their declared types."""


class Grounder(ABC):
    """Decides what/where. ``cost_class`` says whether a call costs money (metered, §8).

    A cloud grounder's calls are charged to the node's budget by the pipelines, one request
    per call; an adapter that retries charges every retry itself
    (``models.metering.charge_cloud_request``) before sending it.
    """

    cost_class: CostClass = "local"
    name: str = ""
    """The adapter's name in results (``grounder`` in a result's ``extra``); set by the
    composition root from the config (``name`` key, else the config group's choice)."""
    composite: bool = False
    """A grounder that delegates to others (``models.chain``): it charges their cloud requests
    and notes who answered itself, instead of the pipeline doing it for it."""

    @property
    def worst_case_s(self) -> float | None:
        """Longest one call can take with all its retries (None: no limit of its own)."""
        return None

    def readiness(self) -> str | None:
        """Why the model cannot answer now (e.g. its key was refused); None when ready."""
        return None

    @abstractmethod
    async def ground(
        self,
        image: Image,
        question: str,
        outputs: list[SemanticRequest] | None = None,
        mode: str = "ground_and_segment",
    ) -> GroundingResult:
        """Answer a grounding question (+ the requested semantic outputs) about one frame."""

    @abstractmethod
    async def point(self, image: Image, query: str) -> list[GroundedTarget]:
        """Point at every instance matching ``query`` (used per tile by segment_all)."""


@dataclass(frozen=True)
class SegmentPrompt:
    """One object to segment: a box, points, or both (a box-capable segmenter uses the box)."""

    box: Box | None = None
    points: list[Point] = field(default_factory=list)


class Segmenter(ABC):
    """Produces pixels from prompts. Calls are synchronous and may be slow; the node runs them
    in a worker thread."""

    cost_class: CostClass = "local"

    def readiness(self) -> str | None:
        """Why the model cannot segment now; None when ready."""
        return None

    @abstractmethod
    def segment_box(self, image: Image, box: Box) -> Mask:
        """Full-image boolean mask of the object inside ``box``."""

    @abstractmethod
    def segment_points(self, image: Image, points: list[Point]) -> Mask:
        """Full-image boolean mask of the object under ``points``."""

    def segment_many(self, image: Image, prompts: list[SegmentPrompt]) -> list[Mask]:
        """One full-image mask per prompt, all on the same image, in one call.

        The tiled pipeline segments every instance with a single call so that segmenters
        with an image encoder (SAM) embed the frame once. The default loops over
        :meth:`segment_box` / :meth:`segment_points`.
        """
        return [
            self.segment_box(image, p.box)
            if p.box is not None
            else self.segment_points(image, p.points)
            for p in prompts
        ]
