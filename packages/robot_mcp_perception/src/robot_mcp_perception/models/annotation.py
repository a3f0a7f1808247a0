"""AnnotationGrounder — the offline default grounder. It is NOT a model.

It answers ground / point / describe / region questions by looking the frame up in a folder
of annotated frames (the ``sample_scenes`` format: ``scene_NNNN.png`` + ``scene_NNNN.json``)
and reading the answer from the annotation. It exists so that the whole vision node runs on
a laptop with no GPU and no API key, on the sample frames; on any other frame it says
honestly that the frame is not annotated and returns no targets.

How it works:

* **Frame lookup by content** (:mod:`.frame_index`): the received image is compared with a
  thumbnail of every stored frame, so it works whichever frame source delivered it (folder,
  or a camera topic replaying the folder, at any resolution). A *crop* of a stored frame
  (a segment_all tile) is located with template matching inside the stored frames.
* **Targets**: annotation polygons are mapped into the received image (window + scale);
  objects less than ``min_visible_fraction`` visible are ignored. Box = visible extent,
  point = a point on the visible part near its centroid, confidence = visible fraction.
* **Label matching** (:mod:`.label_match`): tolerant — "the red mug on the left" finds
  "red mug" (and picks the leftmost one if there are several).
* **Region**: the largest rectangle of the frame clear of every object (+ margin).
* **Semantic outputs** (heuristics, documented): boolean → whether anything matched;
  number → how many matched; list → labels of the matches; text → the frame's description;
  position → ``{"x", "y"}`` pixel of the first match; pose → that position with ``z = 0``,
  ``yaw = 0``. An output whose name/description names a thing ("whether a mug is visible")
  is matched against its own text instead of the question; in describe mode the default
  match set is every object.
"""

from __future__ import annotations

import asyncio
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import structlog

from robot_mcp_perception.models import label_match
from robot_mcp_perception.models._checks import check_image
from robot_mcp_perception.models.base import (
    CostClass,
    GroundedTarget,
    Grounder,
    GroundingResult,
    Image,
    SemanticRequest,
)
from robot_mcp_perception.models.frame_index import FrameIndex, Located
from robot_mcp_perception.models.free_space import largest_free_rect
from robot_mcp_perception.postprocess import mask_box, mask_centroid

log = structlog.get_logger(__name__)

_META_WORDS = frozenset(
    [
        "whether",
        "visible",
        "present",
        "found",
        "seen",
        "see",
        "count",
        "number",
        "how",
        "many",
        "much",
        "scene",
        "description",
        "describe",
        "caption",
        "summary",
        "list",
        "name",
        "label",
        "position",
        "pose",
        "grasp",
        "where",
        "location",
        "target",
        "it",
        "they",
        "if",
        "can",
        "you",
        "true",
        "false",
        "table",
        "image",
        "picture",
        "frame",
        "view",
        "main",
        "brief",
        "short",
        "word",
        "sentence",
        "answer",
        "result",
        "value",
    ]
)
"""Words of an output's name/description that say *what kind* of answer, not *about what*."""


@dataclass(frozen=True)
class _Visible:
    label: str
    box: tuple[int, int, int, int]
    point: tuple[int, int]
    area: int
    fraction: float

    def target(self) -> GroundedTarget:
        return GroundedTarget(self.label, self.box, [self.point], "object", round(self.fraction, 3))


class AnnotationGrounder(Grounder):
    """Offline grounder answering from annotation files stored next to folder frames."""

    cost_class: CostClass = "local"

    def __init__(
        self,
        directory: str,
        full_threshold: float = 0.95,
        crop_threshold: float = 0.8,
        min_visible_fraction: float = 0.05,
        free_space_margin_px: int = 8,
    ) -> None:
        self.directory = Path(directory)
        self.index = FrameIndex.load(
            self.directory, full_threshold=full_threshold, crop_threshold=crop_threshold
        )
        self.min_visible_fraction = min_visible_fraction
        self.free_space_margin_px = free_space_margin_px
        log.info(
            "annotation_grounder_ready",
            directory=str(self.directory),
            frames=len(self.index.frames),
        )

    async def ground(
        self,
        image: Image,
        question: str,
        outputs: list[SemanticRequest] | None = None,
        mode: str = "ground_and_segment",
    ) -> GroundingResult:
        check_image(image)
        located, visible = await asyncio.to_thread(self._visible, image)
        if located is None:
            return self._not_annotated()
        base = visible if mode == "describe" else self._select(question, visible)
        semantic = {
            o.name: v
            for o in outputs or []
            if (v := self._output(o, base, visible, located)) is not None
        }
        reasoning = f"annotation lookup: {located.frame.path.name} (match {located.score:.2f})"
        if mode == "region":
            region = self._free_space(image, visible)
            targets = [region] if region is not None else []
            answer = "free space found" if targets else "no free space on the table"
            return GroundingResult(answer, reasoning, targets, semantic)
        if mode == "describe":
            return GroundingResult(located.frame.description, reasoning, [], semantic)
        labels = sorted({v.label for v in base})
        answer = (
            f"found {len(base)}: {', '.join(labels)}" if base else f"nothing matches {question!r}"
        )
        return GroundingResult(answer, reasoning, [v.target() for v in base], semantic)

    async def point(self, image: Image, query: str) -> list[GroundedTarget]:
        check_image(image)
        located, visible = await asyncio.to_thread(self._visible, image)
        if located is None:
            return []
        return [v.target() for v in self._select(query, visible)]

    def _not_annotated(self) -> GroundingResult:
        return GroundingResult(
            answer=(
                f"this frame is not one of the {len(self.index.frames)} annotated frames in "
                f"{self.directory}; the offline annotation grounder cannot answer"
            ),
            reasoning="no annotated frame matches the image",
        )

    def _visible(self, image: Image) -> tuple[Located | None, list[_Visible]]:
        started = time.perf_counter()
        located = self.index.locate(image)
        if located is None:
            log.info("annotation_frame_unknown", shape=list(image.shape))
            return None, []
        height, width = image.shape[:2]
        x0, y0, x1, y1 = located.window
        sx, sy = width / (x1 - x0), height / (y1 - y0)
        visible = []
        for obj in located.frame.objects:
            canvas = np.zeros((height, width), np.uint8)
            polys = [np.round((p - (x0, y0)) * (sx, sy)).astype(np.int32) for p in obj.polygons]
            cv2.fillPoly(canvas, polys, 1)
            mask = canvas.astype(bool)
            area = int(mask.sum())
            fraction = min(1.0, area / (obj.area * sx * sy))
            box, point = mask_box(mask), mask_centroid(mask)
            if box is None or point is None or fraction < self.min_visible_fraction:
                continue
            visible.append(_Visible(obj.label, box, point, area, fraction))
        log.debug(
            "annotation_lookup",
            frame=located.frame.path.name,
            objects=len(visible),
            duration_ms=round(1000 * (time.perf_counter() - started), 2),
        )
        return located, visible

    @staticmethod
    def _select(query: str, visible: list[_Visible]) -> list[_Visible]:
        return label_match.select(
            query, visible, lambda v: v.label, lambda v: v.point, lambda v: float(v.area)
        )

    def _output(
        self,
        request: SemanticRequest,
        base: list[_Visible],
        visible: list[_Visible],
        located: Located,
    ) -> Any:
        own = f"{request.name.replace('_', ' ')} {request.description}"
        words = label_match.content_tokens(own) - label_match.GENERIC_WORDS - _META_WORDS
        names_something = any(len(w) > 2 for w in words)
        matches = self._select(own, visible) if names_something else base
        if request.type == "boolean":
            return bool(matches)
        if request.type == "number":
            return len(matches)
        if request.type == "list":
            return [v.label for v in matches]
        if request.type == "text":
            return located.frame.description
        if request.type in ("position", "pose") and matches:
            x, y = matches[0].point
            if request.type == "position":
                return {"x": float(x), "y": float(y)}
            return {"x": float(x), "y": float(y), "z": 0.0, "yaw": 0.0}
        return None

    def _free_space(self, image: Image, visible: list[_Visible]) -> GroundedTarget | None:
        height, width = image.shape[:2]
        rect = largest_free_rect(width, height, [v.box for v in visible], self.free_space_margin_px)
        if rect is None:
            return None
        x0, y0, x1, y1 = rect
        return GroundedTarget("free space", rect, [((x0 + x1) // 2, (y0 + y1) // 2)], "region", 1.0)
