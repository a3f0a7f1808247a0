"""GroundedSamGrounder with a fake ``ultralytics`` module (the real one needs weights): lazy
import, clear errors for a missing extra / weights, detections mapped to targets and outputs.
SamSegmenter's tests are in test_models_sam.py."""

from __future__ import annotations

import sys
import types
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from robot_mcp_perception.models.base import (
    ModelError,
    ModelUnavailableError,
    SemanticRequest,
)
from robot_mcp_perception.models.grounded_sam import GroundedSamGrounder

IMAGE = np.zeros((60, 80, 3), np.uint8)


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
    module.YOLOWorld = FakeYOLOWorld  # type: ignore[attr-defined]
    monkeypatch.setitem(sys.modules, "ultralytics", module)
    return module


@pytest.fixture
def weights(tmp_path: Path) -> str:
    path = tmp_path / "yolov8m-world.pt"
    path.write_bytes(b"weights")
    return str(path)


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
    assert model.vocabularies == [["mug", "box"], ["the red mug"]]  # start-up: text encoder check
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
