"""The camera renders the office from the robot's pose (MuJoCo) and annotates each frame from
the renderer's segmentation, saved in a bounded folder before it is published."""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path

import cv2
import numpy as np
import pytest

from robot_sim.camera import Camera
from robot_sim.config import default_world_path
from robot_sim.render.annotate import MIN_PIXELS, describe
from robot_sim.render.renderer import HEIGHT, WIDTH, MujocoRenderer, camera_matrix
from robot_sim.store import SceneStore
from robot_sim.world import World, load_world
from robot_site_map import Pose


@pytest.fixture(scope="module")
def world() -> World:
    return load_world(default_world_path())


@pytest.fixture(scope="module")
def renderer(world: World) -> Iterator[MujocoRenderer]:
    rendering = MujocoRenderer(world)
    yield rendering
    rendering.close()


def at(world: World, place: str) -> Pose:
    return world.map.locations[place].pose()


def polygon_mask(annotation: dict[str, object]) -> np.ndarray:
    mask = np.zeros((HEIGHT, WIDTH), np.uint8)
    for flat in annotation["segmentation"]:  # type: ignore[attr-defined]
        cv2.fillPoly(mask, [np.asarray(flat, np.int32).reshape(-1, 2)], 1)
    return mask.astype(bool)


def test_each_annotation_matches_the_renderers_segmentation(
    world: World, renderer: MujocoRenderer, tmp_path: Path
) -> None:
    camera = Camera(world, SceneStore(tmp_path), renderer)
    for place in ("kitchen", "mailroom", "desk_bob"):
        pose = at(world, place)
        shot = camera.shot(pose)
        doc = json.loads((tmp_path / f"{shot.frame.name}.json").read_text())
        view = renderer.render(pose)
        in_view = {o.index for o in view.objects if (view.instances == o.index).sum() >= MIN_PIXELS}
        assert {a["id"] for a in doc["annotations"]} == in_view
        assert in_view, f"nothing in view at {place}"
        for annotation in doc["annotations"]:
            truth = view.instances == annotation["id"]
            drawn = polygon_mask(annotation)
            iou = (truth & drawn).sum() / (truth | drawn).sum()
            assert iou > 0.9, (place, annotation["label"], iou)
            assert annotation["area"] == int(truth.sum())
            x, y, w, h = annotation["bbox"]
            ys, xs = np.nonzero(truth)
            assert (x, y, x + w - 1, y + h - 1) == (xs.min(), ys.min(), xs.max(), ys.max())


def test_from_the_kitchen_the_camera_sees_the_mug_and_from_the_mailroom_it_does_not(
    world: World, renderer: MujocoRenderer, tmp_path: Path
) -> None:
    camera = Camera(world, SceneStore(tmp_path), renderer)
    kitchen = camera.shot(at(world, "kitchen")).frame
    mailroom = camera.shot(at(world, "mailroom")).frame
    assert set(kitchen.labels) == {"red mug", "green bottle", "white plate"}
    assert kitchen.description == (
        "The kitchen counter. In view: a red mug, a green bottle and a white plate."
    )
    assert "red mug" not in mailroom.labels
    assert sorted(mailroom.labels) == ["cardboard box", "cardboard box", "yellow package"]
    assert kitchen.name.startswith("kitchen-")
    assert mailroom.name.startswith("mailroom-")


def test_a_moved_object_shows_from_the_next_frame(
    world: World, renderer: MujocoRenderer, tmp_path: Path
) -> None:
    camera = Camera(world, SceneStore(tmp_path), renderer)
    before = camera.shot(at(world, "kitchen"))
    assert camera.shot(at(world, "kitchen")).rendered is False  # nothing changed: no render
    world.set_objects("kitchen", ["green bottle", "white plate"])
    try:
        after = camera.shot(at(world, "kitchen"))
    finally:
        world.set_objects("kitchen", ["red mug", "green bottle", "white plate"])
    assert after.rendered
    assert after.frame.name != before.frame.name
    assert "red mug" not in after.frame.labels


def test_a_saved_frame_is_the_published_pixels_with_its_annotation(
    world: World, renderer: MujocoRenderer, tmp_path: Path
) -> None:
    camera = Camera(world, SceneStore(tmp_path), renderer)
    frame = camera.shot(at(world, "kitchen")).frame
    png = cv2.cvtColor(cv2.imread(str(tmp_path / f"{frame.name}.png")), cv2.COLOR_BGR2RGB)
    assert png.tobytes() == frame.data  # lossless
    doc = json.loads((tmp_path / f"{frame.name}.json").read_text())
    assert doc["image"] == {"file_name": f"{frame.name}.png", "width": 640, "height": 480}
    assert (doc["source"], doc["place"]) == ("robot-sim", "kitchen")
    assert doc["pose"] == {"x": 9.0, "y": -3.0, "theta": 0.0}
    assert not list(tmp_path.glob(".*.tmp"))


def test_the_folder_keeps_only_the_newest_frames_and_a_restart_clears_the_old_ones(
    world: World, renderer: MujocoRenderer, tmp_path: Path
) -> None:
    store = SceneStore(tmp_path, keep=3)
    camera = Camera(world, store, renderer)
    names = [camera.shot(Pose(2.0 + 0.5 * i, 0.0, 0.0)).frame.name for i in range(5)]
    assert store.names() == names[2:]
    assert sorted(p.stem for p in tmp_path.glob("*.json")) == sorted(names[2:])
    assert sorted(p.stem for p in tmp_path.glob("*.png")) == sorted(names[2:])
    (tmp_path / "someone-else.json").write_text(json.dumps({"source": "sample_scenes"}))
    assert SceneStore(tmp_path).clear_stale() == 3
    assert [p.name for p in tmp_path.iterdir()] == ["someone-else.json"]


def test_depth_and_the_camera_matrix_describe_the_same_pinhole(
    world: World, renderer: MujocoRenderer
) -> None:
    view = renderer.render(at(world, "kitchen"), depth=True)
    assert view.depth is not None
    assert view.depth.shape == (HEIGHT, WIDTH)
    fx, fy, cx, cy = camera_matrix()
    assert (fx, cx, cy) == (fy, 320.0, 240.0)
    centre = float(view.depth[240, 320])
    assert 0.5 < centre < 3.0  # the counter a metre or so ahead


def test_descriptions_count_and_list_what_is_in_view() -> None:
    assert describe("The shelf.", []) == "The shelf. No objects in view."
    assert describe("The shelf.", ["box", "box", "mug"]) == "The shelf. In view: 2 boxes and a mug."


def test_a_moving_robots_frames_render_at_half_resolution_and_stay_annotated(
    world: World, renderer: MujocoRenderer, tmp_path: Path
) -> None:
    camera = Camera(world, SceneStore(tmp_path), renderer, moving_scale=0.5)
    pose = at(world, "kitchen")
    moving = camera.shot(pose, moving=True)
    standing = camera.shot(pose)
    assert moving.rendered
    assert standing.rendered
    assert moving.frame.name != standing.frame.name
    assert (moving.frame.width, moving.frame.height) == (WIDTH, HEIGHT)
    assert set(moving.frame.labels) == set(standing.frame.labels)
    doc = json.loads((tmp_path / f"{moving.frame.name}.json").read_text())
    view = renderer.render(pose, scale=0.5)
    for annotation in doc["annotations"]:
        truth = view.instances == annotation["id"]
        drawn = polygon_mask(annotation)
        assert (truth & drawn).sum() / (truth | drawn).sum() > 0.9
    with pytest.raises(ValueError, match="scale"):
        renderer.render(pose, scale=0.0)
