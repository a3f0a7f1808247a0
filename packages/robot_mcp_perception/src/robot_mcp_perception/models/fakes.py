"""Scripted fakes of the model ports, shipped beside the real adapters (tests, demos).

``FakeGrounder`` answers from a script and records every call; ``FakeSegmenter`` returns
box-shaped masks and counts calls. Neither touches a network or a model.
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from robot_mcp_perception.models.base import (
    Box,
    CostClass,
    GroundedTarget,
    Grounder,
    GroundingResult,
    Image,
    Mask,
    Point,
    Segmenter,
    SegmentPrompt,
    SemanticRequest,
)

GroundingScript = (
    GroundingResult
    | Sequence[GroundingResult | BaseException]
    | Callable[[Image, str, str], GroundingResult]
)


@dataclass(frozen=True)
class GrounderCall:
    method: str
    """"ground" or "point"."""
    image_shape: tuple[int, ...]
    question: str
    outputs: list[SemanticRequest] = field(default_factory=list)
    mode: str = ""


class FakeGrounder(Grounder):
    """A grounder that answers from a script.

    ``results`` is one :class:`GroundingResult` (always returned), a sequence (one per call,
    the last one repeats; an exception in it is raised for that call), or a callable
    ``(image, question, mode) -> GroundingResult``. ``point()`` answers with the targets of the
    same script (``mode="point"``). ``error`` is raised by every call; ``delay_s`` makes calls
    slow (for timeout/concurrency tests). Calls are recorded in :attr:`calls`.
    """

    def __init__(
        self,
        results: GroundingScript | None = None,
        delay_s: float = 0.0,
        error: BaseException | None = None,
        cost_class: CostClass = "cloud",
    ) -> None:
        self._script = results if results is not None else GroundingResult()
        self.delay_s = delay_s
        self.error = error
        self.cost_class = cost_class
        self.calls: list[GrounderCall] = []

    @property
    def ground_calls(self) -> int:
        return sum(1 for c in self.calls if c.method == "ground")

    @property
    def point_calls(self) -> int:
        return sum(1 for c in self.calls if c.method == "point")

    async def ground(
        self,
        image: Image,
        question: str,
        outputs: list[SemanticRequest] | None = None,
        mode: str = "ground_and_segment",
    ) -> GroundingResult:
        self.calls.append(GrounderCall("ground", image.shape, question, list(outputs or []), mode))
        return await self._answer(image, question, mode)

    async def point(self, image: Image, query: str) -> list[GroundedTarget]:
        self.calls.append(GrounderCall("point", image.shape, query, [], "point"))
        return list((await self._answer(image, query, "point")).targets)

    async def _answer(self, image: Image, question: str, mode: str) -> GroundingResult:
        if self.delay_s > 0:
            await asyncio.sleep(self.delay_s)
        if self.error is not None:
            raise self.error
        script = self._script
        if isinstance(script, GroundingResult):
            return script
        if callable(script):
            return script(image, question, mode)
        if not script:
            return GroundingResult()
        index = min(len(self.calls) - 1, len(script) - 1)
        item = script[index]
        if isinstance(item, BaseException):
            raise item
        return item


@dataclass(frozen=True)
class SegmenterCall:
    method: str
    """"box", "points" or "many"."""
    image_shape: tuple[int, ...]
    prompt: Any


class FakeSegmenter(Segmenter):
    """Box-shaped masks (points: a square of ``point_radius_px``), recording every call.

    ``masks`` optionally scripts the answers: a callable ``(image, prompt) -> Mask`` where the
    prompt is a :class:`SegmentPrompt` — handy for returning implausible masks on purpose.
    """

    def __init__(
        self,
        masks: Callable[[Image, SegmentPrompt], Mask] | None = None,
        point_radius_px: int = 4,
    ) -> None:
        self._masks = masks
        self.point_radius_px = point_radius_px
        self.calls: list[SegmenterCall] = []

    @property
    def call_count(self) -> int:
        return len(self.calls)

    def segment_box(self, image: Image, box: Box) -> Mask:
        self.calls.append(SegmenterCall("box", image.shape, box))
        return self._mask(image, SegmentPrompt(box=box))

    def segment_points(self, image: Image, points: list[Point]) -> Mask:
        self.calls.append(SegmenterCall("points", image.shape, list(points)))
        return self._mask(image, SegmentPrompt(points=list(points)))

    def segment_many(self, image: Image, prompts: list[SegmentPrompt]) -> list[Mask]:
        self.calls.append(SegmenterCall("many", image.shape, list(prompts)))
        return [self._mask(image, p) for p in prompts]

    def _mask(self, image: Image, prompt: SegmentPrompt) -> Mask:
        if self._masks is not None:
            return self._masks(image, prompt)
        mask = np.zeros(image.shape[:2], dtype=bool)
        if prompt.box is not None:
            x0, y0, x1, y1 = prompt.box
            mask[max(0, y0) : max(0, y1), max(0, x0) : max(0, x1)] = True
        r = self.point_radius_px
        for x, y in prompt.points if prompt.box is None else []:
            mask[max(0, y - r) : y + r + 1, max(0, x - r) : x + r + 1] = True
        return mask
