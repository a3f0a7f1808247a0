"""The seeded tabletop scene generator (data/ frames + COCO-style annotations)."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from robot_mcp_perception.sample_scenes import (
    DIFFICULTIES,
    LABELS,
    generate_scenes,
    main,
    polygon_mask,
    render_scene,
)


def test_generated_scenes_are_byte_identical_for_the_same_seed(tmp_path: Path) -> None:
    first = generate_scenes(tmp_path / "a", count=3, seed=7, size=(160, 120))
    second = generate_scenes(tmp_path / "b", count=3, seed=7, size=(160, 120))
    for a, b in zip(first, second, strict=True):
        assert a.read_bytes() == b.read_bytes()
        assert a.with_suffix(".json").read_text() == b.with_suffix(".json").read_text()


def test_a_different_seed_gives_different_frames(tmp_path: Path) -> None:
    a = generate_scenes(tmp_path / "a", count=1, seed=1, size=(160, 120))[0]
    b = generate_scenes(tmp_path / "b", count=1, seed=2, size=(160, 120))[0]
    assert a.read_bytes() != b.read_bytes()


def test_annotation_files_follow_the_documented_format(tmp_path: Path) -> None:
    png = generate_scenes(tmp_path, count=1, size=(160, 120))[0]
    doc = json.loads(png.with_suffix(".json").read_text())
    assert doc["image"] == {"file_name": png.name, "width": 160, "height": 120}
    assert doc["description"].startswith("A ")
    assert doc["annotations"]
    for ann in doc["annotations"]:
        assert set(ann) == {"id", "label", "bbox", "segmentation", "area", "difficulty"}
        assert ann["label"] in LABELS
        assert ann["difficulty"] in DIFFICULTIES
        assert ann["label"].split()[-1] in doc["description"]


def test_object_masks_are_exactly_the_rasterised_polygons() -> None:
    _image, doc = render_scene(2, seed=0, size=(320, 240))
    for ann in doc["annotations"]:
        mask = polygon_mask(ann["segmentation"], 320, 240)
        assert int(mask.sum()) == ann["area"]
        ys, xs = np.nonzero(mask)
        x, y, w, h = ann["bbox"]
        assert (xs.min(), ys.min(), xs.max() - xs.min() + 1, ys.max() - ys.min() + 1) == (
            x,
            y,
            w,
            h,
        )


def test_objects_never_overlap_so_every_mask_is_fully_visible() -> None:
    for index in range(8):
        _, doc = render_scene(index, seed=3, size=(320, 240))
        masks = [polygon_mask(a["segmentation"], 320, 240) for a in doc["annotations"]]
        total = np.sum(masks, axis=0)
        assert total.max() <= 1


def test_the_set_contains_every_hard_case() -> None:
    seen = {
        a["difficulty"] for i in range(8) for a in render_scene(i, 0, (320, 240))[1]["annotations"]
    }
    assert seen == set(DIFFICULTIES)


def test_touching_objects_are_adjacent_without_overlapping() -> None:
    _, doc = render_scene(3, seed=0)
    touching = [a for a in doc["annotations"] if a["difficulty"] == "touching"]
    assert len(touching) == 2
    left, right = sorted(touching, key=lambda a: a["bbox"][0])
    assert left["bbox"][0] + left["bbox"][2] == right["bbox"][0]


def test_the_png_on_disk_is_the_rendered_rgb_frame(tmp_path: Path) -> None:
    png = generate_scenes(tmp_path, count=1, seed=5, size=(160, 120))[0]
    image, _ = render_scene(0, seed=5, size=(160, 120))
    bgr = cv2.imread(str(png))
    assert bgr is not None
    on_disk = cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)
    assert np.array_equal(on_disk, image)


def test_bad_arguments_are_refused(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="count"):
        generate_scenes(tmp_path, count=0)
    with pytest.raises(ValueError, match="size"):
        generate_scenes(tmp_path, count=1, size=(10, 10))


def test_the_cli_writes_the_requested_scenes(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert (
        main([str(tmp_path), "--count", "2", "--seed", "4", "--width", "160", "--height", "120"])
        == 0
    )
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "scene_0000.json",
        "scene_0000.png",
        "scene_0001.json",
        "scene_0001.png",
    ]
    assert "wrote 2 scenes" in capsys.readouterr().out
