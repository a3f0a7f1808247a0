"""SamSegmenter: SAM 3 / SAM 2.1 checkpoints through ultralytics (the ``[sam]`` extra).

``ultralytics`` is imported lazily (not at module import); a missing extra or checkpoint is
a :class:`ModelUnavailableError` at construction (start-up) that says how to fix it. All
model calls run on one worker thread (``ThreadPoolExecutor(max_workers=1)``): GPU access is
serialized, and callers on other threads simply wait their turn. ``segment_many`` sends all
boxes of one frame in one predictor call and all point prompts of the frame in one more (an
(objects × points) array; shorter point lists are padded with SAM's "not a point" label -1),
so a frame is embedded once per prompt kind.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from typing import Any

import cv2
import numpy as np

from robot_mcp_perception.models._checks import check_image, check_points, clip_box
from robot_mcp_perception.models._ultralytics import checked_weights, import_ultralytics, to_numpy
from robot_mcp_perception.models.base import (
    Box,
    CostClass,
    Image,
    Mask,
    ModelError,
    Point,
    Segmenter,
    SegmentPrompt,
)


class SamSegmenter(Segmenter):
    cost_class: CostClass = "local"

    def __init__(self, checkpoint: str, device: str = "cuda", imgsz: int = 1024) -> None:
        weights = checked_weights(checkpoint, "segmenter.checkpoint", "SAM_CHECKPOINT")
        ultralytics = import_ultralytics()
        self.checkpoint = str(weights)
        self.device = device
        self.imgsz = imgsz
        self._pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="sam")
        try:
            self._model = self._pool.submit(ultralytics.SAM, self.checkpoint).result()
        except Exception as exc:  # the library boundary: any load failure is "unavailable"
            self._pool.shutdown(wait=False)
            raise ModelError(f"could not load SAM checkpoint {weights}: {exc}") from exc

    def close(self) -> None:
        self._pool.shutdown(wait=True)

    def segment_box(self, image: Image, box: Box) -> Mask:
        height, width = check_image(image)
        return self.segment_many(image, [SegmentPrompt(box=clip_box(box, width, height))])[0]

    def segment_points(self, image: Image, points: list[Point]) -> Mask:
        height, width = check_image(image)
        return self.segment_many(
            image, [SegmentPrompt(points=check_points(points, width, height))]
        )[0]

    def segment_many(self, image: Image, prompts: list[SegmentPrompt]) -> list[Mask]:
        height, width = check_image(image)
        bgr = cv2.cvtColor(image, cv2.COLOR_RGB2BGR)  # ultralytics reads numpy frames as BGR
        masks: list[Mask | None] = [None] * len(prompts)
        boxed = [i for i, p in enumerate(prompts) if p.box is not None]
        if boxed:
            boxes = [list(clip_box(prompts[i].box, width, height)) for i in boxed]  # type: ignore[arg-type]
            for i, mask in zip(
                boxed, self._predict(bgr, (height, width), bboxes=boxes), strict=True
            ):
                masks[i] = mask
        pointed = [i for i, p in enumerate(prompts) if p.box is None]
        if pointed:
            lists = [
                [list(pt) for pt in check_points(prompts[i].points, width, height)] for i in pointed
            ]
            most = max(len(pts) for pts in lists)
            points = [pts + [pts[0]] * (most - len(pts)) for pts in lists]
            labels = [[1] * len(pts) + [-1] * (most - len(pts)) for pts in lists]
            for i, mask in zip(
                pointed,
                self._predict(bgr, (height, width), points=points, labels=labels),
                strict=True,
            ):
                masks[i] = mask
        return [m for m in masks if m is not None]

    def _predict(self, bgr: Any, shape: tuple[int, int], **prompt: Any) -> list[Mask]:
        expected = len(prompt.get("bboxes", [])) or len(prompt.get("points", [])) or 1

        def run() -> Any:
            return self._model(bgr, device=self.device, imgsz=self.imgsz, verbose=False, **prompt)

        try:
            results = self._pool.submit(run).result()
        except Exception as exc:  # the library boundary (CUDA OOM, bad prompt, …)
            raise ModelError(f"SAM prediction failed: {exc}") from exc
        data = getattr(getattr(results[0], "masks", None), "data", None) if results else None
        if data is None:
            return [np.zeros(shape, dtype=bool) for _ in range(expected)]
        arr = to_numpy(data)
        out = []
        for k in range(expected):
            m = arr[min(k, len(arr) - 1)] if len(arr) else np.zeros(shape)
            if m.shape != shape:
                m = cv2.resize(
                    m.astype(np.float32), (shape[1], shape[0]), interpolation=cv2.INTER_LINEAR
                )
            out.append(np.asarray(m > 0.5, dtype=bool))
        return out
