"""SamSegmenter with a stand-in ``ultralytics`` module (the real one needs torch and weights):
lazy import, clear errors for a missing extra / checkpoint, prompt mapping, one image encode
per frame."""

from __future__ import annotations

import sys
import threading
import types
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
import pytest

from robot_mcp_perception.models.base import (
    GroundedTarget,
    GroundingResult,
    ModelError,
    ModelUnavailableError,
    SegmentPrompt,
)
from robot_mcp_perception.models.fakes import FakeGrounder
from robot_mcp_perception.models.sam import SamSegmenter
from robot_mcp_perception.pipelines.common import PipelineContext
from robot_mcp_perception.pipelines.tiled import segment_all
from robot_mcp_perception.skills import Skill

IMAGE = np.zeros((60, 80, 3), np.uint8)
IMAGE[:, :, 0] = 7  # red: the encoded frame must arrive as BGR (channel 2)


class FakeSamPredictor:
    """ultralytics' SAM ``Predictor``: ``set_image`` runs the image encoder and keeps the
    embedding; a call with prompts runs only the prompt decoder on it (a call with a source
    encodes that source first). Like the real one it answers one mask per prompt in prompt
    order, numbered by ``boxes.cls``, drops masks scoring below ``conf``, and refuses prompts
    without an image, ragged point lists and points/labels of different lengths."""

    def __init__(self, cfg: Any = None, overrides: dict[str, Any] | None = None) -> None:
        self.overrides = dict(overrides or {})
        self.sam: FakeSAM | None = None
        self.frame: np.ndarray | None = None

    def setup_model(self, model: Any = None, verbose: bool = True) -> None:
        self.sam = model.owner
        self.sam.predictors.append(self)

    def set_image(self, image: np.ndarray) -> None:
        assert self.sam is not None, "setup_model first"
        self.sam.threads.add(threading.current_thread().name)
        self.frame = None  # the real one resets its embedding before encoding
        if self.sam.fail:
            raise RuntimeError("CUDA out of memory")
        self.sam.encodes += 1
        self.frame = image.copy()

    def __call__(
        self,
        source: Any = None,
        model: Any = None,
        stream: bool = False,
        bboxes: list[list[int]] | None = None,
        points: list[list[list[int]]] | None = None,
        labels: list[list[int]] | None = None,
    ) -> list[Any]:
        assert self.sam is not None, "setup_model first"
        if source is not None:
            self.set_image(source)
        if self.frame is None:  # the real predictor has no source to iterate
            raise TypeError("'NoneType' object is not iterable")
        if bboxes is not None and points is not None and len(bboxes) != len(points):
            raise RuntimeError("Sizes of tensors must match")  # one object per row of each
        if points is not None:
            if len({len(p) for p in points}) > 1:
                raise ValueError("expected sequence of length 3 at dim 1")  # ragged → no tensor
            if labels is None or [len(lb) for lb in labels] != [len(p) for p in points]:
                raise AssertionError("Number of points should match number of labels")
        self.sam.threads.add(threading.current_thread().name)
        self.sam.calls.append(
            {"bboxes": bboxes, "points": points, "labels": labels, "frame": self.frame}
        )
        h, w = self.frame.shape[:2]
        masks, kept = [], []
        for k, (x0, y0, x1, y1) in enumerate(bboxes or []):
            if (x0, y0, x1, y1) in self.sam.low_score_boxes:
                continue
            m = np.zeros((h, w), np.float32)
            m[y0:y1, x0:x1] = 1.0
            masks.append(m)
            kept.append(k)
        for k, pts in enumerate(points or []):
            m = np.zeros((h // 2, w // 2), np.float32)  # another resolution: must be resized
            for j, (x, y) in enumerate(pts):
                if labels is not None and labels[k][j] == -1:  # SAM's "not a point" padding
                    continue
                m[y // 2, x // 2] = 1.0
            masks.append(m)
            kept.append(k)
        if bboxes == [[0, 0, 1, 1]]:
            return [types.SimpleNamespace(masks=None, boxes=None)]
        return [
            types.SimpleNamespace(
                masks=types.SimpleNamespace(data=np.stack(masks)) if masks else None,
                boxes=types.SimpleNamespace(cls=np.asarray(kept, np.float32)),
            )
        ]


class FakeSAM:
    """``ultralytics.SAM``: calling it encodes the image and decodes the prompts in one go, as
    the real model does on every call; ``task_map`` names its predictor class."""

    instances: ClassVar[list[FakeSAM]] = []

    def __init__(self, path: str) -> None:
        self.path = path
        self.model = types.SimpleNamespace(owner=self)  # the network a predictor is set up on
        self.predictors: list[FakeSamPredictor] = []
        self.calls: list[dict[str, Any]] = []  # prompt decoder runs
        self.encodes = 0  # image encoder runs
        self.threads: set[str] = set()
        self.fail = False
        self.low_score_boxes: set[tuple[int, int, int, int]] = set()
        FakeSAM.instances.append(self)

    @property
    def task_map(self) -> dict[str, dict[str, type[FakeSamPredictor]]]:
        return {"segment": {"predictor": FakeSamPredictor}}

    def __call__(self, source: Any, stream: bool = False, **kwargs: Any) -> list[Any]:
        prompts = {k: kwargs.pop(k, None) for k in ("bboxes", "points", "labels")}
        predictor = FakeSamPredictor(overrides=kwargs)
        predictor.setup_model(self.model)
        return predictor(source, **prompts)


@pytest.fixture
def fake_ultralytics(monkeypatch: pytest.MonkeyPatch) -> types.ModuleType:
    module = types.ModuleType("ultralytics")
    module.SAM = FakeSAM  # type: ignore[attr-defined]
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
    sam = SamSegmenter(weights, device="cpu", imgsz=512)
    model = FakeSAM.instances[-1]
    assert model.path == weights
    settings = model.predictors[-1].overrides
    assert (settings["device"], settings["imgsz"], settings["model"]) == ("cpu", 512, weights)
    box_mask = sam.segment_box(IMAGE, (10, 5, 30, 25))
    assert box_mask.shape == (60, 80)
    assert box_mask.sum() == 400
    point_mask = sam.segment_points(IMAGE, [(40, 30)])
    assert point_mask.shape == (60, 80)
    assert point_mask[30, 40]
    assert model.calls[0]["bboxes"] == [[10, 5, 30, 25]]
    assert model.calls[1]["points"] == [[[40, 30]]]
    assert model.calls[1]["labels"] == [[1]]
    assert np.array_equal(model.calls[0]["frame"], IMAGE[:, :, ::-1])  # BGR, as ultralytics reads
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
    assert model.encodes == 1
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
    assert bool(masks[2][50, 5])
    assert len(model.calls) == 2  # one batched box call + one point call
    assert model.calls[0]["bboxes"] == [[0, 0, 10, 10], [20, 20, 40, 30]]


def test_sam_encodes_a_frame_with_box_and_point_prompts_once(
    fake_ultralytics: Any, weights: str
) -> None:
    sam = SamSegmenter(weights)
    masks = sam.segment_many(
        IMAGE,
        [
            SegmentPrompt(points=[(5, 50)]),
            SegmentPrompt(box=(0, 0, 10, 10)),
            SegmentPrompt(points=[(60, 40), (62, 42)]),
            SegmentPrompt(box=(20, 20, 40, 30), points=[(30, 25)]),
        ],
    )
    model = FakeSAM.instances[-1]
    assert model.encodes == 1
    assert [c["frame"] is model.predictors[-1].frame for c in model.calls] == [True, True]
    assert model.calls[0]["bboxes"] == [[0, 0, 10, 10], [20, 20, 40, 30]]
    assert model.calls[1]["points"] == [[[5, 50], [5, 50]], [[60, 40], [62, 42]]]
    # each mask goes back to its prompt's place
    assert [bool(masks[0][50, 5]), int(masks[1].sum()), bool(masks[2][42, 62])] == [True, 100, True]
    assert int(masks[3].sum()) == 200


def test_sam_reuses_the_embedding_for_later_prompts_on_the_same_pixels(
    fake_ultralytics: Any, weights: str
) -> None:
    sam = SamSegmenter(weights)
    sam.segment_box(IMAGE, (0, 0, 10, 10))
    sam.segment_points(IMAGE.copy(), [(5, 5)])  # same pixels, another array
    model = FakeSAM.instances[-1]
    assert (model.encodes, len(model.calls)) == (1, 2)


def test_sam_encodes_again_when_the_frame_changes(fake_ultralytics: Any, weights: str) -> None:
    sam = SamSegmenter(weights)
    frame = IMAGE.copy()
    sam.segment_box(frame, (0, 0, 10, 10))
    frame[0, 0] = 255  # the same buffer with new pixels is a new frame
    sam.segment_box(frame, (0, 0, 10, 10))
    sam.segment_box(frame[:30], (0, 0, 10, 10))  # another shape
    model = FakeSAM.instances[-1]
    assert model.encodes == 3
    assert model.calls[1]["frame"][0, 0].tolist() == [255, 255, 255]
    assert model.calls[2]["frame"].shape == (30, 80, 3)


async def test_segment_all_with_sam_encodes_the_frame_once_including_point_retries(
    fake_ultralytics: Any, weights: str
) -> None:
    sam = SamSegmenter(weights)
    model = FakeSAM.instances[-1]
    model.low_score_boxes = {(10, 5, 30, 25)}  # its mask is dropped: retried with its point
    grounding = GroundingResult(
        targets=[
            GroundedTarget("cup", (10, 5, 30, 25), [(20, 15)]),
            GroundedTarget("box", (40, 30, 60, 50), [(50, 40)]),
            GroundedTarget("pen", None, [(70, 10)]),
        ]
    )
    grounder = FakeGrounder()
    skill = Skill("everything", "segment_all", segment=True)
    result = await segment_all(skill, IMAGE, PipelineContext(grounder, sam), reuse=grounding)
    assert grounder.calls == []  # a re-used grounding: only the segmenter runs
    assert model.encodes == 1
    assert [(c["bboxes"] is not None, c["points"] is not None) for c in model.calls] == [
        (True, False),
        (False, True),
        (False, True),
    ]
    assert model.calls[2]["points"] == [[[20, 15]]]
    assert all(d.mask is not None for d in result.detections)
    assert bool(result.detections[0].mask[15, 20])  # type: ignore[index]


def test_sam_gives_a_prompt_whose_mask_was_dropped_an_empty_mask_not_a_neighbours(
    fake_ultralytics: Any, weights: str
) -> None:
    sam = SamSegmenter(weights)
    FakeSAM.instances[-1].low_score_boxes = {(0, 0, 10, 10)}
    first, second = sam.segment_many(
        IMAGE, [SegmentPrompt(box=(0, 0, 10, 10)), SegmentPrompt(box=(20, 20, 40, 30))]
    )
    assert not first.any()
    assert int(second.sum()) == 200
    assert bool(second[25, 30])


def test_sam_runs_every_call_on_its_single_worker_thread(
    fake_ultralytics: Any, weights: str
) -> None:
    sam = SamSegmenter(weights)
    frames = [np.full((60, 80, 3), i, np.uint8) for i in range(4)]
    threads = [
        threading.Thread(target=sam.segment_box, args=(frame, (0, 0, 5, 5))) for frame in frames
    ]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout=10)
    model = FakeSAM.instances[-1]
    assert (model.encodes, len(model.calls)) == (4, 4)
    # each decode ran on the embedding of its own frame
    assert sorted(int(c["frame"][0, 0, 0]) for c in model.calls) == [0, 1, 2, 3]
    assert len(model.threads) == 1
    assert next(iter(model.threads)).startswith("sam")


def test_sam_without_masks_in_the_answer_returns_empty_masks(
    fake_ultralytics: Any, weights: str
) -> None:
    assert not SamSegmenter(weights).segment_box(IMAGE, (0, 0, 1, 1)).any()


def test_sam_with_no_prompts_returns_no_masks_without_encoding(
    fake_ultralytics: Any, weights: str
) -> None:
    assert SamSegmenter(weights).segment_many(IMAGE, []) == []
    assert FakeSAM.instances[-1].encodes == 0


def test_sam_prediction_failures_are_model_errors_and_the_next_call_encodes_afresh(
    fake_ultralytics: Any, weights: str
) -> None:
    sam = SamSegmenter(weights)
    model = FakeSAM.instances[-1]
    sam.segment_box(IMAGE, (0, 0, 5, 5))
    model.fail = True
    with pytest.raises(ModelError, match="CUDA out of memory"):
        sam.segment_box(IMAGE + 1, (0, 0, 5, 5))  # another frame: its encode fails
    model.fail = False
    assert int(sam.segment_box(IMAGE, (0, 0, 5, 5)).sum()) == 25  # the first frame again
    assert model.encodes == 2  # the failed encode dropped the first frame's embedding


def test_sam_refuses_prompts_outside_the_frame_before_encoding(
    fake_ultralytics: Any, weights: str
) -> None:
    sam = SamSegmenter(weights)
    with pytest.raises(ValueError, match="no area"):
        sam.segment_many(IMAGE, [SegmentPrompt(points=[(1, 1)]), SegmentPrompt(box=(90, 0, 99, 9))])
    with pytest.raises(ValueError, match="inside"):
        sam.segment_points(IMAGE, [(500, 500)])
    assert FakeSAM.instances[-1].encodes == 0


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
