"""Scenes: deterministic pixels, annotations that are exactly the objects' pixels, places that
never look alike (the grounder finds frames by content), the scenes folder contract."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from robot_mcp_navigation.motion.base import Pose
from robot_mcp_perception.models.frame_index import FrameIndex
from robot_sim.camera import Camera
from robot_sim.config import default_world_path
from robot_sim.scenes import CORRIDOR, render_place
from robot_sim.store import SceneStore, frame_name
from robot_sim.world import ObjectLook, load_world


@pytest.fixture
def camera(tmp_path: Path) -> Camera:
    return Camera(load_world(default_world_path()), SceneStore(tmp_path / "scenes"))


def test_the_same_contents_give_the_same_bytes(camera: Camera) -> None:
    first = camera.scene("kitchen")
    again = camera.scene("kitchen")
    assert first.pixels.shape == (480, 640, 3)
    assert first.pixels.tobytes() == again.pixels.tobytes()
    assert frame_name(first) == frame_name(again)


def test_each_annotation_is_exactly_its_objects_pixels(camera: Camera) -> None:
    look = ObjectLook(shape="mug", colour=(200, 35, 40))
    scene = render_place("test", (128, 128, 124), "A test table.", [("red mug", look)])
    [mug] = scene.annotations
    mask = np.zeros((480, 640), np.uint8)
    cv2.fillPoly(mask, [np.asarray(mug["segmentation"][0], np.int32).reshape(-1, 2)], 1)
    red = np.all(np.abs(scene.pixels.astype(int) - (200, 35, 40)) < 30, axis=2)
    assert mug["area"] == int(mask.sum())
    assert (red & mask.astype(bool)).sum() / mask.sum() > 0.99
    assert (red & ~mask.astype(bool)).sum() == 0
    assert scene.description == "A test table. On it: a red mug."


@pytest.mark.parametrize("shape", ["mug", "bottle", "parcel", "box", "scissors", "plate"])
def test_every_shape_draws_one_annotated_object(shape: str) -> None:
    look = ObjectLook.model_validate({"shape": shape, "colour": (10, 200, 10)})
    scene = render_place("p", (128, 128, 124), "", [("thing", look), ("thing", look)])
    assert [a["label"] for a in scene.annotations] == ["thing", "thing"]
    assert all(a["area"] > 300 for a in scene.annotations)
    assert scene.description == "On it: 2 things."


def test_no_two_views_look_alike_to_the_grounder(camera: Camera, tmp_path: Path) -> None:
    """Every place, the corridor, and the kitchen without its mug: thumbnail similarity far
    below the grounder's 0.95 full-frame threshold, so each frame is found as itself."""
    camera.prepare()
    camera.world.set_objects("kitchen", ["green bottle", "white plate"])
    camera.frame("kitchen")
    index = FrameIndex.load(tmp_path / "scenes")
    assert len(index.frames) == len(camera.world.places) + 2
    thumbs = np.stack([f.thumb.ravel() for f in index.frames])
    similarity = thumbs @ thumbs.T
    np.fill_diagonal(similarity, 0.0)
    assert similarity.max() < 0.8


def test_a_saved_frame_is_a_lossless_png_with_its_annotation(
    camera: Camera, tmp_path: Path
) -> None:
    stored = camera.frame("mailroom")
    folder = tmp_path / "scenes"
    png, doc = (
        folder / f"{stored.name}.png",
        json.loads((folder / f"{stored.name}.json").read_text()),
    )
    pixels = cv2.cvtColor(cv2.imread(str(png)), cv2.COLOR_BGR2RGB)
    assert pixels.tobytes() == stored.data  # what is published is what is stored
    assert doc["image"] == {"file_name": png.name, "width": 640, "height": 480}
    assert doc["place"] == "mailroom"
    assert [a["label"] for a in doc["annotations"]] == [
        "yellow package", "cardboard box", "cardboard box",
    ]  # fmt: skip
    assert (
        doc["description"] == "The mailroom shelf. On it: a yellow package and 2 cardboard boxes."
    )
    assert not list(folder.glob(".*.tmp"))
    assert camera.frame("mailroom") is stored  # rendered and saved once


def test_the_camera_view_is_the_place_the_robot_stands_at(camera: Camera) -> None:
    kitchen = camera.world.map.locations["kitchen"].pose()
    assert camera.view_of(kitchen, driving=False) == "kitchen"
    assert camera.view_of(Pose(kitchen.x + 0.3, kitchen.y), driving=False) == "kitchen"
    assert camera.view_of(Pose(kitchen.x + 2.0, kitchen.y), driving=False) == CORRIDOR
    assert camera.view_of(kitchen, driving=True) == CORRIDOR
    corridor = camera.frame(CORRIDOR)
    assert corridor.name.startswith("corridor-")
