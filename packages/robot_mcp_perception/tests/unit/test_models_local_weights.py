"""SamSegmenter and GroundedSamGrounder with a fake ``ultralytics`` module (the real one needs
GPU weights): lazy import, clear errors for a missing extra / checkpoint, prompt mapping."""

from __future__ import annotations

import sys
import threading
import types
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
import pytest

from robot_mcp_perception.models.base import (
    ModelError,
    ModelUnavailableError,
    SegmentPrompt,
    SemanticRequest,
)
from robot_mcp_perception.models.grounded_sam import GroundedSamGrounder
from robot_mcp_perception.models.sam import SamSegmenter

IMAGE = np.zeros((60, 80, 3), np.uint8)


class FakeSAM:
    instances: ClassVar[list[FakeSAM]] = []

    def __init__(self, path: str) -> None:
        self.path = path
        self.calls: list[dict[str, Any]] = []
        self.threads: set[str] = set()
        self.fail = False
        FakeSAM.instances.append(self)

    def __call__(self, image: Any, **kwargs: Any) -> list[Any]:
        self.calls.append(kwargs)
        self.threads.add(threading.current_thread().name)
        if self.fail:
            raise RuntimeError("CUDA out of memory")
        h, w = image.shape[:2]
        masks = []
        for x0, y0, x1, y1 in kwargs.get("bboxes") or []:
            m = np.zeros((h, w), np.float32)
            m[y0:y1, x0:x1] = 1.0
            masks.append(m)
        labels = kwargs.get("labels") or []
        for k, pts in enumerate(kwargs.get("points") or []):
            m = np.zeros((h // 2, w // 2), np.float32)  # another resolution: must be resized
            for j, (x, y) in enumerate(pts):
                if labels and labels[k][j] == -1:  # SAM's padding label: not a point
                    continue
                m[y // 2, x // 2] = 1.0
            masks.append(m)
        if kwargs.get("bboxes") == [[0, 0, 1, 1]]:
            return [types.SimpleNamespace(masks=None)]
        return [types.SimpleNamespace(masks=types.SimpleNamespace(data=np.stack(masks)))]


class FakeBoxes:
    def __init__(self, xyxy: list[list[float]], conf: list[float], cls: list[int]) -> None:
        self.xyxy, self.conf, self.cls = np.asarray(xyxy), np.asarray(conf), np.asarray(cls)


class FakeYOLOWorld:
    def __init__(self, path: str) -> None:
        self.path = path
        self.vocabularies: list[list[str]] = []
        self.fail = False

    def set_classes(self, classes: list[str]) -> None:
        self.vocabularies.append(list(classes))

    def predict(self, image: Any, **kwargs: Any) -> list[Any]:
        if self.fail:
            raise RuntimeError("bad weights")
        boxes = FakeBoxes([[10, 10, 30, 30], [50, 20, 70, 40]], [0.9, 0.6], [0, 0])
        names = {0: self.vocabularies[-1][0]}
        return [types.SimpleNamespace(boxes=boxes, names=names)]


@pytest.fixture
def fake_ultralytics(monkeypatch: pytest.MonkeyPatch) -> types.ModuleType:
    module = types.ModuleType("ultralytics")
    module.SAM = FakeSAM  # type: ignore[attr-defined]
    module.YOLOWorld = FakeYOLOWorld  # type: ignore[attr-defined]
    monkeypatch.setitem(sys.modules, "ultralytics", module)
    return module


@pytest.fixture
def weights(tmp_path: Path) -> str:
    path = tmp_path / "sam2.1_b.pt"
    path.write_bytes(b"weights")
    return str(path)


def test_sam_maps_box_and_point_prompts_to_full_image_masks(
    fake_ultralytics: Any, weights: str
) -> None:
    sam = SamSegmenter(weights, device="cpu")
    model = FakeSAM.instances[-1]
    assert model.path == weights
    box_mask = sam.segment_box(IMAGE, (10, 5, 30, 25))
    assert box_mask.shape == (60, 80)
    assert box_mask.sum() == 400
    point_mask = sam.segment_points(IMAGE, [(40, 30)])
    assert point_mask.shape == (60, 80)
    assert point_mask[30, 40]
    assert model.calls[0]["bboxes"] == [[10, 5, 30, 25]]
    assert model.calls[0]["device"] == "cpu"
    assert model.calls[1]["points"] == [[[40, 30]]]
    assert model.calls[1]["labels"] == [[1]]
    sam.close()


def test_sam_segments_all_point_prompts_of_a_frame_in_one_call(
    fake_ultralytics: Any, weights: str
) -> None:
    sam = SamSegmenter(weights)
    masks = sam.segment_many(
        IMAGE,
        [
            SegmentPrompt(points=[(10, 10)]),
            SegmentPrompt(points=[(40, 30), (44, 34), (48, 38)]),
            SegmentPrompt(points=[(70, 50), (60, 40)]),
        ],
    )
    model = FakeSAM.instances[-1]

    assert len(model.calls) == 1  # one predictor call: the image is encoded once
    assert model.calls[0]["points"] == [
        [[10, 10], [10, 10], [10, 10]],
        [[40, 30], [44, 34], [48, 38]],
        [[70, 50], [60, 40], [70, 50]],
    ]
    assert model.calls[0]["labels"] == [[1, -1, -1], [1, 1, 1], [1, 1, -1]]
    assert [bool(m[10, 10]) for m in masks] == [True, False, False]
    assert [bool(masks[1][30, 40]), bool(masks[1][38, 48])] == [True, True]
    assert [bool(masks[2][50, 70]), bool(masks[2][40, 60])] == [True, True]


def test_sam_segments_all_boxes_of_a_frame_in_one_call(fake_ultralytics: Any, weights: str) -> None:
    sam = SamSegmenter(weights)
    masks = sam.segment_many(
        IMAGE,
        [
            SegmentPrompt(box=(0, 0, 10, 10)),
            SegmentPrompt(box=(20, 20, 40, 30)),
            SegmentPrompt(points=[(5, 50)]),
        ],
    )
    model = FakeSAM.instances[-1]
    assert [int(m.sum()) for m in masks[:2]] == [100, 200]
    assert len(model.calls) == 2  # one batched box call + one point call
    assert model.calls[0]["bboxes"] == [[0, 0, 10, 10], [20, 20, 40, 30]]


def test_sam_runs_every_call_on_its_single_worker_thread(
    fake_ultralytics: Any, weights: str
) -> None:
    sam = SamSegmenter(weights)
    threads = [
        threading.Thread(target=sam.segment_box, args=(IMAGE, (0, 0, 5, 5))) for _ in range(4)
    ]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout=10)
    model = FakeSAM.instances[-1]
    assert len(model.calls) == 4
    assert len(model.threads) == 1
    assert next(iter(model.threads)).startswith("sam")


def test_sam_without_masks_in_the_answer_returns_empty_masks(
    fake_ultralytics: Any, weights: str
) -> None:
    assert not SamSegmenter(weights).segment_box(IMAGE, (0, 0, 1, 1)).any()


def test_sam_prediction_failures_are_model_errors(fake_ultralytics: Any, weights: str) -> None:
    sam = SamSegmenter(weights)
    FakeSAM.instances[-1].fail = True
    with pytest.raises(ModelError, match="CUDA out of memory"):
        sam.segment_box(IMAGE, (0, 0, 5, 5))


def test_sam_without_the_extra_names_the_extra_to_install(
    monkeypatch: pytest.MonkeyPatch, weights: str
) -> None:
    monkeypatch.setitem(sys.modules, "ultralytics", None)
    with pytest.raises(ModelUnavailableError, match=r"uv sync --extra sam"):
        SamSegmenter(weights)


def test_sam_with_a_missing_checkpoint_names_the_path_and_setting(
    fake_ultralytics: Any, tmp_path: Path
) -> None:
    missing = tmp_path / "sam3.pt"
    with pytest.raises(
        ModelUnavailableError, match=r"sam3.pt does not exist.*segmenter.checkpoint"
    ):
        SamSegmenter(str(missing))
    with pytest.raises(ModelUnavailableError, match="SAM_CHECKPOINT"):
        SamSegmenter("")


def test_sam_load_failures_are_model_errors(monkeypatch: pytest.MonkeyPatch, weights: str) -> None:
    module = types.ModuleType("ultralytics")

    def broken(path: str) -> None:
        raise RuntimeError("not a checkpoint")

    module.SAM = broken  # type: ignore[attr-defined]
    monkeypatch.setitem(sys.modules, "ultralytics", module)
    with pytest.raises(ModelError, match="not a checkpoint"):
        SamSegmenter(weights)


async def test_grounded_sam_detects_the_query_and_answers_outputs(
    fake_ultralytics: Any, weights: str
) -> None:
    grounder = GroundedSamGrounder(weights, classes=["mug", "box"])
    outputs = [
        SemanticRequest("found", "boolean"),
        SemanticRequest("n", "number"),
        SemanticRequest("l", "list"),
        SemanticRequest("t", "text"),
        SemanticRequest("p", "position"),
        SemanticRequest("q", "pose"),
    ]
    result = await grounder.ground(IMAGE, "the red mug", outputs)
    assert [(t.label, t.box, t.points, t.confidence) for t in result.targets] == [
        ("the red mug", (10, 10, 30, 30), [(20, 20)], 0.9),
        ("the red mug", (50, 20, 70, 40), [(60, 30)], 0.6),
    ]
    assert result.outputs["found"] is True
    assert result.outputs["n"] == 2
    assert result.outputs["p"] == {"x": 20.0, "y": 20.0}
    assert result.outputs["q"]["yaw"] == 0.0
    assert result.outputs["t"].startswith("detected:")
    model = grounder._model
    assert model.vocabularies == [["the red mug"]]
    await grounder.point(IMAGE, "every object")
    assert model.vocabularies[-1] == ["mug", "box"]
    described = await grounder.ground(IMAGE, "describe", mode="describe")
    assert described.targets == []
    region = await grounder.ground(IMAGE, "free space", mode="region")
    assert [t.kind for t in region.targets] == ["region"]
    grounder.close()


async def test_grounded_sam_errors_are_clear(
    fake_ultralytics: Any, weights: str, tmp_path: Path
) -> None:
    with pytest.raises(ModelUnavailableError, match=r"grounder\.weights"):
        GroundedSamGrounder(str(tmp_path / "yolov8s-world.pt"))
    grounder = GroundedSamGrounder(weights)
    grounder._model.fail = True
    with pytest.raises(ModelError, match="bad weights"):
        await grounder.point(IMAGE, "mug")


def test_grounded_sam_without_the_extra_names_the_extra(
    monkeypatch: pytest.MonkeyPatch, weights: str
) -> None:
    monkeypatch.setitem(sys.modules, "ultralytics", None)
    with pytest.raises(ModelUnavailableError, match=r"\[sam\] extra"):
        GroundedSamGrounder(weights)
