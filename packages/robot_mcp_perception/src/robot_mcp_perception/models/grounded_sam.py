"""GroundedSamGrounder: the fully local grounder (no cloud) — an open-vocabulary detector.

Detections come from YOLO-World weights through ultralytics (``YOLOWorld(weights)``, the
``[sam]`` extra; weights path from config). The query becomes the detector's class
vocabulary (a generic query such as "every object" uses ``classes`` from config); the masks
come from the configured segmenter, as with any grounder — together they are the
"grounded SAM" combination of the spec. Semantic outputs are derived from the detections:
boolean → anything detected, number → count, list → labels, text → a one-line summary,
position/pose → the first detection's centre in pixels. Region mode returns the largest
rectangle clear of every detection.
"""

from __future__ import annotations

import asyncio
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import cv2

from robot_mcp_perception.models import label_match
from robot_mcp_perception.models._checks import check_image
from robot_mcp_perception.models._ultralytics import checked_weights, import_ultralytics, to_numpy
from robot_mcp_perception.models.base import (
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


class GroundedSamGrounder(Grounder):
    cost_class: CostClass = "local"

    def __init__(
        self,
        weights: str,
        device: str = "cpu",
        confidence: float = 0.25,
        classes: list[str] | tuple[str, ...] | None = None,
    ) -> None:
        path = checked_weights(weights, "grounder.weights", "GROUNDER_WEIGHTS")
        ultralytics = import_ultralytics()
        self.weights = str(path)
        self.device = device
        self.confidence = confidence
        self.classes = [str(c) for c in (classes or DEFAULT_CLASSES)]
        self._pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="grounded-sam")
        try:
            self._model = self._pool.submit(ultralytics.YOLOWorld, self.weights).result()
        except Exception as exc:  # the library boundary
            self._pool.shutdown(wait=False)
            raise ModelError(f"could not load detector weights {path}: {exc}") from exc

    def close(self) -> None:
        self._pool.shutdown(wait=True)

    async def ground(
        self,
        image: Image,
        question: str,
        outputs: list[SemanticRequest] | None = None,
        mode: str = "ground_and_segment",
    ) -> GroundingResult:
        check_image(image)
        vocabulary = self.classes if mode in ("describe", "region") else self._vocabulary(question)
        targets = await self._detect(image, vocabulary)
        semantic = {
            o.name: v for o in outputs or [] if (v := _semantic(o.type, targets)) is not None
        }
        summary = ", ".join(t.label for t in targets) or "nothing"
        if mode == "region":
            height, width = image.shape[:2]
            rect = largest_free_rect(width, height, [t.box for t in targets if t.box is not None])
            region = (
                []
                if rect is None
                else [
                    GroundedTarget(
                        "free space",
                        rect,
                        [((rect[0] + rect[2]) // 2, (rect[1] + rect[3]) // 2)],
                        "region",
                        1.0,
                    )
                ]
            )
            return GroundingResult(
                f"detected: {summary}", "open-vocabulary detector", region, semantic
            )
        kept = [] if mode == "describe" else targets
        return GroundingResult(f"detected: {summary}", "open-vocabulary detector", kept, semantic)

    async def point(self, image: Image, query: str) -> list[GroundedTarget]:
        check_image(image)
        return await self._detect(image, self._vocabulary(query))

    def _vocabulary(self, query: str) -> list[str]:
        return self.classes if label_match.is_generic(query) else [query.strip()]

    async def _detect(self, image: Image, vocabulary: list[str]) -> list[GroundedTarget]:
        bgr = cv2.cvtColor(image, cv2.COLOR_RGB2BGR)

        def run() -> Any:
            self._model.set_classes(vocabulary)
            return self._model.predict(bgr, conf=self.confidence, device=self.device, verbose=False)

        try:
            results = await asyncio.wrap_future(self._pool.submit(run))
        except Exception as exc:  # the library boundary
            raise ModelError(f"open-vocabulary detection failed: {exc}") from exc
        if not results:
            return []
        boxes = results[0].boxes
        xyxy, conf, cls = to_numpy(boxes.xyxy), to_numpy(boxes.conf), to_numpy(boxes.cls)
        names = getattr(results[0], "names", None) or dict(enumerate(vocabulary))
        targets = []
        for (x0, y0, x1, y1), score, c in zip(xyxy, conf, cls, strict=True):
            box = (round(float(x0)), round(float(y0)), round(float(x1)), round(float(y1)))
            centre = ((box[0] + box[2]) // 2, (box[1] + box[3]) // 2)
            label = str(names.get(int(c), vocabulary[0]))
            targets.append(GroundedTarget(label, box, [centre], "object", float(score)))
        return targets


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
