"""The speed settings both SAM segmenters share (``segmenter.imgsz`` / ``precision`` /
``tf32``, issue 30), and how one call's prompts are split into the two decoder batches.

- ``precision``: ``fp32``; ``bf16`` (``torch.autocast`` around encoder and decoder, CUDA or
  CPU); ``fp16`` (CUDA only); ``auto`` (default): bf16 on CUDA, fp32 on the CPU.
- ``tf32`` (default true): TensorFloat-32 matmuls/convolutions for the fp32 parts on CUDA
  (a process-wide torch setting; no effect on the CPU).
- ``imgsz``: the encoder's input size; ``None`` is the model's native size, any other value
  must be a positive multiple of the model's patch stride.
"""

from __future__ import annotations

import contextlib
import importlib
from dataclasses import dataclass
from typing import Any, Literal

from robot_mcp_perception.models._checks import check_points, clip_box
from robot_mcp_perception.models.base import Box, SegmentPrompt

Precision = Literal["auto", "fp32", "bf16", "fp16"]


def checked_imgsz(imgsz: int | None, native: int, stride: int, model: str) -> int:
    """``imgsz`` (``None``: ``native``); a size off the patch stride is refused at start-up."""
    if imgsz is None:
        return native
    if imgsz <= 0 or imgsz % stride:
        raise ValueError(
            f"segmenter.imgsz {imgsz} is not a positive multiple of {stride} (the input stride "
            f"of {model}); use {native} (native) or another multiple of {stride}"
        )
    return imgsz


def resolved_precision(precision: str, device: str) -> Precision:
    """The precision to run at: ``auto`` resolved for ``device``; bad values refused."""
    if precision not in ("auto", "fp32", "bf16", "fp16"):
        raise ValueError(f"segmenter.precision must be auto, fp32, bf16 or fp16: {precision!r}")
    cuda = is_cuda(device)
    if precision == "fp16" and not cuda:
        raise ValueError("segmenter.precision fp16 needs a CUDA device (use bf16 or fp32)")
    if precision == "auto":
        return "bf16" if cuda and cuda_available() else "fp32"
    return precision  # type: ignore[return-value]


def enable_tf32(tf32: bool, device: str) -> bool:
    """Turn TF32 on for a CUDA device when asked; whether it is on."""
    if not (tf32 and is_cuda(device)):
        return False
    torch = importlib.import_module("torch")
    torch.backends.cuda.matmul.allow_tf32 = True
    torch.backends.cudnn.allow_tf32 = True
    return True


def autocast(precision: Precision, device: str) -> contextlib.AbstractContextManager[Any]:
    """``torch.autocast`` to bf16 (or fp16) around model calls; nothing for fp32."""
    if precision not in ("bf16", "fp16"):
        return contextlib.nullcontext()
    torch = importlib.import_module("torch")
    dtype = torch.bfloat16 if precision == "bf16" else torch.float16
    context: contextlib.AbstractContextManager[Any] = torch.autocast(
        device_type="cuda" if is_cuda(device) else "cpu", dtype=dtype
    )
    return context


def is_cuda(device: str) -> bool:
    return str(device).startswith("cuda")


def cuda_available() -> bool:
    try:
        torch = importlib.import_module("torch")
    except ImportError:
        return False
    return bool(torch.cuda.is_available())


@dataclass(frozen=True)
class PromptBatches:
    """One call's prompts as the two decoder batches: all boxes, and all point-only prompts
    (SAM reads a box and points given together as prompts of one object, so they are not
    mixed). ``boxed`` / ``pointed`` are the prompts' indices in the call."""

    boxed: list[int]
    boxes: list[Box]
    pointed: list[int]
    points: list[list[list[int]]]


def prompt_batches(prompts: list[SegmentPrompt], width: int, height: int) -> PromptBatches:
    """Split and check one call's prompts (boxes clipped, points inside the frame)."""
    boxed = [i for i, p in enumerate(prompts) if p.box is not None]
    pointed = [i for i, p in enumerate(prompts) if p.box is None]
    boxes = [clip_box(prompts[i].box, width, height) for i in boxed]  # type: ignore[arg-type]
    points = [[list(pt) for pt in check_points(prompts[i].points, width, height)] for i in pointed]
    return PromptBatches(boxed, boxes, pointed, points)
