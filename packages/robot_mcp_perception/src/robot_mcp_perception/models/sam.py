"""SamSegmenter: SAM 3 / SAM 2.1 checkpoints through ultralytics (the ``[sam]`` extra).

``ultralytics`` is imported lazily (not at module import); a missing extra or checkpoint is
a :class:`ModelUnavailableError` at construction (start-up) that says how to fix it. All
model calls run on one worker thread (``ThreadPoolExecutor(max_workers=1)``): GPU access is
serialized, and callers on other threads simply wait their turn.

One image encode per frame: the adapter drives ultralytics' SAM predictor (the class the
model's ``task_map`` names) directly. ``set_image`` runs the image encoder once; then the
prompt decoder runs on that embedding once for all boxes of the call and once for all
point-only prompts (an (objects × points) array; shorter point lists are padded with SAM's
"not a point" label -1). Boxes and points do not share a decoder call because SAM reads a
box and points given together as prompts of one object. The embedding is kept, keyed by a
digest of the pixels, so a later call on the same frame (the tiled pipeline's point retry,
the box → points fallback of ground_and_segment) decodes without encoding again.

ultralytics drops masks scoring below ``conf`` and numbers the rest by prompt (``boxes.cls``);
masks are matched to prompts by that number, and a prompt whose mask was dropped gets an
empty mask (never a neighbour's).

Speed settings (issue 30), chosen in config (:mod:`._sam_settings`, shared with the
transformers segmenter :mod:`.hf_sam`):

- ``imgsz``: the encoder's input size; ``null`` picks the model's native size (SAM 3: 1008,
  SAM / SAM 2.x: 1024). A size that is not a multiple of the model's patch stride (SAM 3: 14,
  others: 16) is refused at start-up — ultralytics would round it and warn on every call.
- ``precision``: ``fp32``; ``bf16`` (autocast); ``fp16`` (ultralytics' own half-precision
  model, CUDA only); ``auto`` (default): bf16 on CUDA, fp32 on the CPU. Masks keep their
  shape and count whatever the precision.
- ``tf32`` (default true): TensorFloat-32 for the fp32 parts on CUDA.
- All boxes of a frame go to the decoder in one batch (above).
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from robot_mcp_perception.models import _sam_settings
from robot_mcp_perception.models._checks import check_image, check_points, clip_box
from robot_mcp_perception.models._sam_settings import Precision
from robot_mcp_perception.models._ultralytics import (
    checked_weights,
    frame_key,
    import_ultralytics,
    sam_predictor,
    to_numpy,
)
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

NATIVE_IMGSZ = {"sam3": 1008, "sam": 1024}
"""The encoder input size each model family was trained at (SAM 3: 72 × 14-px patches)."""
PATCH_STRIDE = {"sam3": 14, "sam": 16}


def model_family(checkpoint: str) -> str:
    """``sam3`` for SAM 3 checkpoints (ultralytics tells them by the file name), else ``sam``."""
    return "sam3" if "sam3" in Path(checkpoint).stem else "sam"


def checked_imgsz(imgsz: int | None, checkpoint: str) -> int:
    """The encoder input size: the model's native one by default; a size that is not a
    multiple of the model's stride is refused (ultralytics would round it and warn per call)."""
    family = model_family(checkpoint)
    return _sam_settings.checked_imgsz(
        imgsz, NATIVE_IMGSZ[family], PATCH_STRIDE[family], Path(checkpoint).name
    )


class SamSegmenter(Segmenter):
    cost_class: CostClass = "local"

    def __init__(
        self,
        checkpoint: str,
        device: str = "cuda",
        imgsz: int | None = None,
        precision: Precision = "auto",
        tf32: bool = True,
    ) -> None:
        weights = checked_weights(checkpoint, "segmenter.checkpoint", "SAM_CHECKPOINT")
        self.imgsz = checked_imgsz(imgsz, str(weights))
        self.precision: Precision = _sam_settings.resolved_precision(precision, device)
        ultralytics = import_ultralytics()
        self.tf32 = _sam_settings.enable_tf32(tf32, device)
        self.checkpoint = str(weights)
        self.device = device
        self._encoded: bytes | None = None  # frame_key of the embedding the predictor holds
        self._pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="sam")
        half = self.precision == "fp16"  # ultralytics' own half model, not autocast

        def load() -> Any:
            model = ultralytics.SAM(self.checkpoint)
            return sam_predictor(model, self.checkpoint, device, self.imgsz, half=half)

        try:
            self._predictor = self._pool.submit(load).result()
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
        if not prompts:
            return []
        batches = _sam_settings.prompt_batches(prompts, width, height)
        most = max((len(pts) for pts in batches.points), default=0)
        points = [pts + [pts[0]] * (most - len(pts)) for pts in batches.points]
        labels = [[1] * len(pts) + [-1] * (most - len(pts)) for pts in batches.points]

        decodes: list[tuple[list[int], dict[str, Any]]] = [
            (batches.boxed, {"bboxes": [list(box) for box in batches.boxes]}),
            (batches.pointed, {"points": points, "labels": labels}),
        ]

        def run() -> list[Mask]:
            masks: dict[int, Mask] = {}
            bf16: Precision = "bf16" if self.precision == "bf16" else "fp32"  # fp16: half model
            with _sam_settings.autocast(bf16, self.device):
                self._encode(image)
                for indices, prompt in decodes:
                    if indices:  # the prompt decoder only: the embedding is the frame's
                        answer = self._predictor(**prompt)
                        found = _masks_by_prompt(answer, len(indices), (height, width))
                        masks.update(zip(indices, found, strict=True))
            return [masks[i] for i in range(len(prompts))]

        try:
            return self._pool.submit(run).result()
        except Exception as exc:  # the library boundary (CUDA OOM, bad prompt, …)
            raise ModelError(f"SAM prediction failed: {exc}") from exc

    def _encode(self, image: Image) -> None:
        """Run the image encoder unless the predictor holds this frame's embedding already.

        Runs on the worker thread only, so the key and the predictor's state change together.
        """
        key = frame_key(image)
        if key == self._encoded:
            return
        self._encoded = None  # a failed encode leaves no embedding to trust
        self._predictor.set_image(cv2.cvtColor(image, cv2.COLOR_RGB2BGR))  # ultralytics: BGR
        self._encoded = key


def _masks_by_prompt(results: Any, count: int, shape: tuple[int, int]) -> list[Mask]:
    """One full-frame mask per prompt; ``boxes.cls`` says which prompt each mask answers."""
    masks = [np.zeros(shape, dtype=bool) for _ in range(count)]
    result = results[0] if results else None
    data = getattr(getattr(result, "masks", None), "data", None)
    if data is None:
        return masks
    arr = to_numpy(data)
    numbers = getattr(getattr(result, "boxes", None), "cls", None)
    order = [int(n) for n in to_numpy(numbers)] if numbers is not None else range(len(arr))
    for k, m in zip(order, arr, strict=False):
        if m.shape != shape:
            m = cv2.resize(
                m.astype(np.float32), (shape[1], shape[0]), interpolation=cv2.INTER_LINEAR
            )
        masks[k] = np.asarray(m > 0.5, dtype=bool)
    return masks
