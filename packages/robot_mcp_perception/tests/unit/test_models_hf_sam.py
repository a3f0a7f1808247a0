"""HfSamSegmenter's start-up refusals, checked before transformers is imported: each names the
setting (SAM_CHECKPOINT) and what is wrong. The model itself is tested against the real
library in tests/models/test_hf_sam.py."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest

from robot_mcp_perception.models import _sam_settings
from robot_mcp_perception.models.base import ModelUnavailableError, SegmentPrompt
from robot_mcp_perception.models.hf_sam import HfSamSegmenter


def folder(tmp_path: Path, model_type: str, *files: str) -> Path:
    path = tmp_path / "sam"
    path.mkdir()
    (path / "config.json").write_text(json.dumps({"model_type": model_type}))
    for name in files:
        (path / name).write_bytes(b"{}")
    return path


def test_no_folder_configured_names_the_setting() -> None:
    with pytest.raises(ModelUnavailableError, match=r"no SAM model folder .*SAM_CHECKPOINT"):
        HfSamSegmenter("")


def test_an_absent_folder_names_the_path_and_the_setting(tmp_path: Path) -> None:
    with pytest.raises(ModelUnavailableError, match=r"absent does not exist .*SAM_CHECKPOINT"):
        HfSamSegmenter(str(tmp_path / "absent"))


@pytest.mark.parametrize(
    ("files", "missing"),
    [
        ((), "model weights: expected model.safetensors or pytorch_model.bin"),
        (("model.safetensors",), "processor settings: expected processor_config.json"),
    ],
)
def test_a_folder_missing_a_file_names_the_file_and_the_setting(
    tmp_path: Path, files: tuple[str, ...], missing: str
) -> None:
    path = folder(tmp_path, "sam2", *files)
    with pytest.raises(ModelUnavailableError, match=rf"SAM_CHECKPOINT\) has no {missing}"):
        HfSamSegmenter(str(path))


def test_a_folder_of_another_model_says_which_ones_are_served_and_how_to_save_sam3(
    tmp_path: Path,
) -> None:
    path = folder(tmp_path, "sam3_video", "model.safetensors", "processor_config.json")
    with pytest.raises(ModelUnavailableError, match=r"'sam3_video' model.*sam2 and sam3_tracker"):
        HfSamSegmenter(str(path))


def test_fp16_on_the_cpu_is_refused_before_anything_loads(tmp_path: Path) -> None:
    path = folder(tmp_path, "sam2", "model.safetensors", "processor_config.json")
    with pytest.raises(ValueError, match="fp16 needs a CUDA device"):
        HfSamSegmenter(str(path), device="cpu", precision="fp16")


def test_without_the_extra_the_error_names_the_extra_to_install(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    path = folder(tmp_path, "sam2", "model.safetensors", "processor_config.json")
    monkeypatch.setitem(sys.modules, "transformers", None)
    with pytest.raises(ModelUnavailableError, match=r"uv sync --extra hf"):
        HfSamSegmenter(str(path), device="cpu")


def test_prompts_split_into_one_box_batch_and_one_point_batch_in_call_order() -> None:
    batches = _sam_settings.prompt_batches(
        [
            SegmentPrompt(points=[(5, 5), (500, 5)]),  # the point outside is dropped
            SegmentPrompt(box=(-10, 0, 50, 40)),  # clipped to the frame
            SegmentPrompt(box=(1, 1, 9, 9), points=[(3, 3)]),  # a box wins over its points
        ],
        width=80,
        height=60,
    )
    assert (batches.boxed, batches.boxes) == ([1, 2], [(0, 0, 50, 40), (1, 1, 9, 9)])
    assert (batches.pointed, batches.points) == ([0], [[[5, 5]]])


def test_sizes_off_the_stride_are_refused_and_none_is_the_native_size() -> None:
    assert _sam_settings.checked_imgsz(None, 1008, 14, "sam3") == 1008
    assert _sam_settings.checked_imgsz(448, 1008, 14, "sam3") == 448
    with pytest.raises(ValueError, match=r"imgsz 500 is not a positive multiple of 32"):
        _sam_settings.checked_imgsz(500, 1024, 32, "sam2")
    with pytest.raises(ValueError, match="positive multiple"):
        _sam_settings.checked_imgsz(0, 1024, 32, "sam2")
