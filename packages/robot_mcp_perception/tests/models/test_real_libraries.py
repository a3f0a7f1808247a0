"""Every model adapter against its real library on the CPU, random weights (issue 30 item 3):
loading through the adapter's normal path, shapes, one mask per prompt in prompt order, the
embedding reused on the same frame, offline loading (network disabled), and the fakes of the
fast unit tests rejecting what the real library rejects."""

from __future__ import annotations

import importlib.util
import os
import socket
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from robot_mcp_perception.models import random_weights
from robot_mcp_perception.models.base import ModelUnavailableError, SegmentPrompt
from robot_mcp_perception.models.owlv2 import Owlv2Grounder
from robot_mcp_perception.models.sam import SamSegmenter

from .conftest import MISSING

pytestmark = pytest.mark.slow
FRAME = np.zeros((120, 160, 3), np.uint8)
FRAME[30:90, 40:120] = (200, 60, 40)
PROMPTS = [
    SegmentPrompt(box=(40, 30, 120, 90)),
    SegmentPrompt(box=(0, 0, 60, 50)),
    SegmentPrompt(points=[(80, 60)]),
]


def test_the_model_libraries_are_installed_where_ci_runs() -> None:
    if os.environ.get("CI"):
        assert not MISSING, f"CI runs without {MISSING}: scripts/install-model-libs.sh failed"


@pytest.fixture(scope="module")
def sam21_path(checkpoints: Path) -> Path:
    return random_weights.sam_checkpoint(checkpoints, "sam2.1_t.pt")


@pytest.fixture(scope="module")
def sam21(sam21_path: Path) -> SamSegmenter:
    return SamSegmenter(str(sam21_path), device="cpu", imgsz=256)


def test_sam21_through_ultralytics_gives_one_full_frame_mask_per_prompt(
    sam21: SamSegmenter, no_network: list[str]
) -> None:
    encodes = _count_encodes(sam21)
    masks = sam21.segment_many(FRAME, PROMPTS)
    again = sam21.segment_box(FRAME, (40, 30, 120, 90))  # same frame: decoder only

    assert [m.shape for m in masks] == [(120, 160)] * 3
    assert all(m.dtype == np.bool_ for m in masks)
    assert again.shape == (120, 160)
    assert encodes() == 1
    assert no_network == []


def test_sam21_masks_keep_shape_and_count_in_bf16(sam21: SamSegmenter) -> None:
    fp32 = sam21.segment_many(FRAME, PROMPTS)
    sam21.precision = "bf16"
    try:
        sam21._encoded = None
        bf16 = sam21.segment_many(FRAME, PROMPTS)
    finally:
        sam21.precision = "fp32"
        sam21._encoded = None
    assert [m.shape for m in bf16] == [m.shape for m in fp32]


def test_sam_sizes_default_to_each_models_native_size_and_refuse_off_stride_sizes(
    checkpoints: Path, sam21_path: Path
) -> None:
    assert SamSegmenter(str(sam21_path), device="cpu").imgsz == 1024
    with pytest.raises(ValueError, match=r"segmenter\.imgsz 1000 .* multiple of 16"):
        SamSegmenter(str(sam21_path), device="cpu", imgsz=1000)
    sam3 = checkpoints / "off" / "sam3.pt"
    sam3.parent.mkdir(exist_ok=True)
    sam3.write_bytes(b"not read: the size is checked first")
    with pytest.raises(ValueError, match=r"imgsz 1024 .* multiple of 14.*use 1008"):
        SamSegmenter(str(sam3), device="cpu", imgsz=1024)


def test_sam3_through_ultralytics_segments_box_prompts_at_a_small_size(
    checkpoints: Path, no_network: list[str]
) -> None:
    """SAM 3 built by ultralytics' own interactive builder (its full config: ~470 M
    parameters), loaded by the adapter, one call at imgsz 112 on a small frame: covers the
    checkpoint format, the predictor class the model names, the prompt mapping and the mask
    shapes — not the native-size speed (benchmarks/perception_gpu.py)."""
    path = random_weights.sam_checkpoint(checkpoints, "sam3.pt")
    sam3 = SamSegmenter(str(path), device="cpu", imgsz=112)
    try:
        masks = sam3.segment_many(FRAME, PROMPTS[:2])
    finally:
        sam3.close()
        path.unlink()
    assert [m.shape for m in masks] == [(120, 160)] * 2
    assert no_network == []


@pytest.fixture(scope="module")
def ultralytics_sam21(sam21_path: Path) -> Any:
    from robot_mcp_perception.models._ultralytics import import_ultralytics

    return import_ultralytics().SAM(str(sam21_path))


@pytest.mark.parametrize(
    ("prompt", "error"),
    [
        ({"bboxes": [[10, 10, 50, 50]]}, TypeError),  # no image encoded yet
        ({"points": [[[5, 5]], [[5, 5], [9, 9]]], "labels": [[1], [1, 1]]}, ValueError),
        ({"points": [[[5, 5], [9, 9]]], "labels": [[1]]}, Exception),
    ],
    ids=["no-image", "ragged-points", "labels-mismatch"],
)
def test_the_fake_sam_predictor_rejects_what_the_real_one_rejects(
    sam21_path: Path, ultralytics_sam21: Any, prompt: dict[str, Any], error: type[Exception]
) -> None:
    from robot_mcp_perception.models._ultralytics import sam_predictor

    fakes = _fast_test_module("test_models_sam.py")  # the fake the fast unit tests use

    path = str(sam21_path)
    real = sam_predictor(ultralytics_sam21, path, "cpu", 256)  # a fresh predictor: no image
    fake = fakes.FakeSamPredictor()
    fake.setup_model(fakes.FakeSAM(path).model)
    for predictor in (real, fake):
        if "bboxes" not in prompt:
            predictor.set_image(FRAME)
        with pytest.raises(error):
            predictor(**prompt)


@pytest.fixture(scope="module")
def owl_folder(checkpoints: Path) -> Path:
    return random_weights.owlv2_folder(checkpoints / "owlv2")


async def test_owlv2_loads_every_part_from_its_folder_and_detects_offline(
    owl_folder: Path, no_network: list[str]
) -> None:
    grounder = Owlv2Grounder(str(owl_folder), confidence=0.0, classes=["mug", "box"])
    try:
        found = await grounder.ground(FRAME, "the red mug")
        generic = await grounder.point(FRAME, "every object")
    finally:
        grounder.close()
    assert found.targets
    assert all(t.label == "the red mug" for t in found.targets)
    assert all(0 <= t.box[0] < t.box[2] <= 160 for t in found.targets if t.box)
    assert {t.label for t in generic} <= {"mug", "box"}
    assert len(found.targets) <= 20
    assert no_network == []


def test_owlv2_names_the_missing_file_and_the_setting(owl_folder: Path, tmp_path: Path) -> None:
    partial = tmp_path / "partial"
    partial.mkdir()
    (partial / "config.json").write_text((owl_folder / "config.json").read_text())
    with pytest.raises(ModelUnavailableError, match=r"GROUNDER_WEIGHTS.*no model weights"):
        Owlv2Grounder(str(partial))
    with pytest.raises(ModelUnavailableError, match="does not exist"):
        Owlv2Grounder(str(tmp_path / "absent"))
    with pytest.raises(ModelUnavailableError, match="GROUNDER_WEIGHTS"):
        Owlv2Grounder("")


def test_yolo_world_offline_fails_at_start_naming_the_offline_choice(
    checkpoints: Path, no_network: list[str]
) -> None:
    from robot_mcp_perception.models._ultralytics import import_ultralytics
    from robot_mcp_perception.models.grounded_sam import GroundedSamGrounder

    ultralytics = import_ultralytics()
    model = ultralytics.YOLOWorld("yolov8s-worldv2.yaml")  # the library's config, random weights
    path = checkpoints / "yolov8s-worldv2.pt"
    model.save(str(path))
    with pytest.raises(ModelUnavailableError, match="grounder=owlv2"):
        GroundedSamGrounder(str(path), classes=["mug"])


def test_a_corrupt_frame_is_still_skipped_after_ultralytics_is_imported(
    tmp_path: Path, no_network: list[str]
) -> None:
    """ultralytics patches Pillow's Image.open to install pi-heif from the network on an
    unreadable file; the adapter's import puts Pillow's own back, so the folder source skips
    the file instead of losing its thread to ModuleNotFoundError."""
    from robot_mcp_perception.frames import FolderFrameSource
    from robot_mcp_perception.models._ultralytics import import_ultralytics

    import_ultralytics()
    corrupt = tmp_path / "b.png"
    corrupt.write_bytes(b"\x89PNG\r\n\x1a\n not really a png")
    source = FolderFrameSource(str(tmp_path))

    assert source.read(corrupt) is None
    assert source.skipped == [corrupt]
    assert no_network == []


def test_the_network_guard_itself_refuses_a_connection(no_network: list[str]) -> None:
    """The guard the tests above rely on fails a non-loopback connect (and records it)."""
    with socket.socket() as s, pytest.raises(OSError, match="network disabled"):
        s.connect(("192.0.2.1", 80))
    assert no_network == ["connect ('192.0.2.1', 80)"]


def _fast_test_module(name: str) -> Any:
    path = Path(__file__).parents[1] / "unit" / name
    spec = importlib.util.spec_from_file_location(f"fast_{path.stem}", path)
    assert spec is not None
    assert spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _count_encodes(sam: SamSegmenter) -> Any:
    predictor = sam._predictor
    original = predictor.set_image
    calls = []

    def counted(image: Any) -> Any:
        calls.append(1)
        return original(image)

    predictor.set_image = counted
    sam._encoded = None
    return lambda: len(calls)


def test_the_gpu_benchmark_runs_on_the_cpu_in_smoke_mode(tmp_path: Path) -> None:
    """The script's own entry point, in this process (the libraries are imported already)."""
    import json

    script = Path(__file__).parents[4] / "benchmarks" / "perception_gpu.py"
    spec = importlib.util.spec_from_file_location("perception_gpu", script)
    assert spec is not None
    assert spec.loader is not None
    benchmark = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(benchmark)
    out = tmp_path / "perception_gpu.json"

    benchmark.main(["--smoke", "--device", "cpu", "--out", str(out)])

    report = json.loads(out.read_text())
    assert set(report["models"]) == {"sam2.1_t.pt", "hf:sam2"}
    for model in report["models"].values():
        assert model["5_prompts"]["masks"] == [5, [120, 160]]
        assert model["5_prompts"]["same_frame"]["p50_ms"] > 0
    assert report["models"]["hf:sam2"]["library"] == "transformers (Apache-2.0)"
    assert report["owlv2"]["fps"] > 0
