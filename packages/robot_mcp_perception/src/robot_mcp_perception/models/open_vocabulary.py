"""What every on-board open-vocabulary detector answers, whatever the library behind it.

:class:`OpenVocabularyGrounder` turns a detector (``_detect``: an RGB frame and a list of
class texts → boxes, scores, class indices) into a :class:`~.base.Grounder`. The query
becomes the detector's vocabulary (a generic query such as "every object", and the describe
and region modes, use ``classes`` from config); the masks come from the configured segmenter,
as with any grounder. Semantic outputs are derived from the detections: boolean → anything
detected, number → count, list → labels, text → a one-line summary, position/pose → the first
detection's centre in pixels. Region mode returns the largest rectangle clear of every
detection. Model calls run on one worker thread (one model, calls serialized).
"""

from __future__ import annotations

import asyncio
from abc import abstractmethod
from concurrent.futures import ThreadPoolExecutor
from typing import Any

from robot_mcp_perception.models import label_match
from robot_mcp_perception.models._checks import check_image
from robot_mcp_perception.models.base import (
    Box,
    CostClass,
    GroundedTarget,
    Grounder,
    GroundingResult,
    Image,
    ModelError,
    SemanticRequest,
)
from robot_mcp_perception.models.free_space import largest_free_rect

DEFAULT_CLASSES = ("mug", "cup", "box", "package", "bottle", "scissors", "plate", "bowl", "tool")
Detection = tuple[Box, float, int]
"""(box in pixels, score, index into the vocabulary)."""


class OpenVocabularyGrounder(Grounder):
    cost_class: CostClass = "local"
    reasoning = "open-vocabulary detector"

    def __init__(self, classes: list[str] | tuple[str, ...] | None, thread_name: str) -> None:
        self.classes = [str(c) for c in (classes or DEFAULT_CLASSES)]
        if not self.classes:
            raise ValueError("classes must name at least one class (generic queries use them)")
        self._pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix=thread_name)

    def close(self) -> None:
        self._pool.shutdown(wait=True)

    @abstractmethod
    def _detect(self, image: Image, vocabulary: list[str]) -> list[Detection]:
        """Run the detector (on the worker thread); library errors propagate."""

    async def ground(
        self,
        image: Image,
        question: str,
        outputs: list[SemanticRequest] | None = None,
        mode: str = "ground_and_segment",
    ) -> GroundingResult:
        check_image(image)
        vocabulary = self.classes if mode in ("describe", "region") else self._vocabulary(question)
        targets = await self.detect(image, vocabulary)
        semantic = {
            o.name: v for o in outputs or [] if (v := _semantic(o.type, targets)) is not None
        }
        summary = f"detected: {', '.join(t.label for t in targets) or 'nothing'}"
        if mode == "region":
            height, width = image.shape[:2]
            rect = largest_free_rect(width, height, [t.box for t in targets if t.box is not None])
            region = [] if rect is None else [_region(rect)]
            return GroundingResult(summary, self.reasoning, region, semantic)
        kept = [] if mode == "describe" else targets
        return GroundingResult(summary, self.reasoning, kept, semantic)

    async def point(self, image: Image, query: str) -> list[GroundedTarget]:
        check_image(image)
        return await self.detect(image, self._vocabulary(query))

    def _vocabulary(self, query: str) -> list[str]:
        return self.classes if label_match.is_generic(query) else [query.strip()]

    async def detect(self, image: Image, vocabulary: list[str]) -> list[GroundedTarget]:
        try:
            found = await asyncio.wrap_future(self._pool.submit(self._detect, image, vocabulary))
        except ModelError:
            raise
        except Exception as exc:  # the library boundary
            raise ModelError(f"open-vocabulary detection failed: {exc}") from exc
        targets = []
        for box, score, index in found:
            centre = ((box[0] + box[2]) // 2, (box[1] + box[3]) // 2)
            label = vocabulary[index] if 0 <= index < len(vocabulary) else vocabulary[0]
            targets.append(GroundedTarget(label, box, [centre], "object", float(score)))
        return targets


def _region(rect: Box) -> GroundedTarget:
    anchor = ((rect[0] + rect[2]) // 2, (rect[1] + rect[3]) // 2)
    return GroundedTarget("free space", rect, [anchor], "region", 1.0)


def _semantic(type_: str, targets: list[GroundedTarget]) -> Any:
    if type_ == "boolean":
        return bool(targets)
    if type_ == "number":
        return len(targets)
    if type_ == "list":
        return [t.label for t in targets]
    if type_ == "text":
        return "detected: " + (", ".join(t.label for t in targets) or "nothing")
    if type_ in ("position", "pose") and targets:
        x, y = targets[0].points[0]
        base = {"x": float(x), "y": float(y)}
        return base if type_ == "position" else {**base, "z": 0.0, "yaw": 0.0}
    return None
