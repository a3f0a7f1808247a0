"""The permissive segmenter (issue 30 item 6): SAM 2.1 and SAM 3 through the real
``transformers`` on the CPU, random weights from the library's own configs (``Sam2Config``,
``Sam3TrackerConfig``; small layouts, small frames): loaded offline from a folder through the
config choice ``segmenter=hf_sam``, one full-frame mask per prompt in prompt order, one encode
per frame, the size and precision settings."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from robot_mcp_perception.composition import compose_config, instantiate_adapter
from robot_mcp_perception.models import random_weights
from robot_mcp_perception.models.base import Segmenter, SegmentPrompt
from robot_mcp_perception.models.hf_sam import HfSamSegmenter

from .conftest import network_disabled

pytestmark = pytest.mark.slow
FRAME = np.zeros((60, 80, 3), np.uint8)
FRAME[15:45, 20:60] = (200, 60, 40)
PROMPTS = [
    SegmentPrompt(box=(20, 15, 60, 45)),
    SegmentPrompt(points=[(40, 30)]),
    SegmentPrompt(box=(0, 0, 30, 25)),
    SegmentPrompt(points=[(5, 5), (9, 50)]),  # a longer point list: padded by the processor
]


@pytest.fixture(scope="module")
def sam2_folder(checkpoints: Path) -> Path:
    return random_weights.hf_sam_folder(checkpoints / "hf_sam2", "sam2")


@pytest.fixture(scope="module")
def sam2(sam2_folder: Path) -> Iterator[Segmenter]:
    """Built from the shipped YAML through the composition root, as `segmenter=hf_sam` is,
    with the network disabled."""
    with pytest.MonkeyPatch.context() as patch, network_disabled() as attempts:
        patch.setenv("SAM_CHECKPOINT", str(sam2_folder))
        cfg = compose_config(["segmenter=hf_sam", "segmenter.device=cpu"])
        segmenter = instantiate_adapter(cfg.segmenter, Segmenter, "segmenter")
    assert attempts == []
    yield segmenter
    segmenter.close()


def test_sam2_through_transformers_loads_offline_from_the_config_choice_and_segments(
    sam2: HfSamSegmenter, no_network: list[str]
) -> None:
    encodes = _count_encodes(sam2)
    masks = sam2.segment_many(FRAME, PROMPTS)
    alone = [sam2.segment_many(FRAME, [p])[0] for p in PROMPTS]  # same frame: decoder only

    assert isinstance(sam2, HfSamSegmenter)
    assert (sam2.family, sam2.imgsz, sam2.precision, sam2.tf32) == ("sam2", 64, "fp32", False)
    assert [m.shape for m in masks] == [(60, 80)] * 4
    assert all(m.dtype == np.bool_ for m in masks)
    assert len({m.tobytes() for m in masks}) == 4  # four different answers …
    assert all(np.array_equal(a, b) for a, b in zip(masks, alone, strict=True))  # … in order
    assert encodes() == 1
    assert no_network == []


def test_sam2_masks_keep_shape_and_count_in_bf16(sam2: HfSamSegmenter) -> None:
    sam2.precision = "bf16"
    try:
        masks = sam2.segment_many(FRAME[::-1].copy(), PROMPTS)
    finally:
        sam2.precision = "fp32"
    assert [m.shape for m in masks] == [(60, 80)] * 4


def test_sam2_runs_at_another_size_and_refuses_one_off_its_stride(sam2_folder: Path) -> None:
    with pytest.raises(ValueError, match=r"imgsz 80 is not a positive multiple of 32"):
        HfSamSegmenter(str(sam2_folder), device="cpu", imgsz=80)
    larger = HfSamSegmenter(str(sam2_folder), device="cpu", imgsz=96)
    try:
        masks = larger.segment_many(FRAME, PROMPTS[:2])
    finally:
        larger.close()
    assert larger.imgsz == 96
    assert [m.shape for m in masks] == [(60, 80)] * 2


def test_sam3_through_transformers_segments_box_and_point_prompts(
    checkpoints: Path, no_network: list[str]
) -> None:
    folder = random_weights.hf_sam_folder(checkpoints / "hf_sam3", "sam3_tracker")
    sam3 = HfSamSegmenter(str(folder), device="cpu", imgsz=84)  # off its native 56: resized
    try:
        encodes = _count_encodes(sam3)
        masks = sam3.segment_many(FRAME, PROMPTS)
        again = sam3.segment_box(FRAME, (20, 15, 60, 45))
    finally:
        sam3.close()
    assert (sam3.family, sam3.imgsz) == ("sam3_tracker", 84)
    assert [m.shape for m in masks] == [(60, 80)] * 4
    assert np.array_equal(again, masks[0])
    assert encodes() == 1
    assert no_network == []


def _count_encodes(sam: HfSamSegmenter) -> Any:
    model = sam._model
    original = model.get_image_embeddings
    calls = []

    def counted(*args: Any, **kwargs: Any) -> Any:
        calls.append(1)
        return original(*args, **kwargs)

    model.get_image_embeddings = counted
    sam._encoded = None
    return lambda: len(calls)
