"""AnnotationGrounder: the offline grounder answering from annotation files."""

from __future__ import annotations

import asyncio
import json
import os
from pathlib import Path

import cv2
import numpy as np
import pytest

from robot_mcp_perception.models.annotation import AnnotationGrounder
from robot_mcp_perception.models.base import ModelUnavailableError, SemanticRequest
from robot_mcp_perception.models.free_space import largest_free_rect
from robot_mcp_perception.models.label_match import is_generic, label_score, select, tokens
from robot_mcp_perception.sample_scenes import generate_scenes, render_scene

SIZE = (160, 120)


@pytest.fixture(scope="module")
def scenes(tmp_path_factory: pytest.TempPathFactory) -> Path:
    directory = tmp_path_factory.mktemp("scenes")
    generate_scenes(directory, count=6, seed=0, size=SIZE)
    return directory


@pytest.fixture(scope="module")
def grounder(scenes: Path) -> AnnotationGrounder:
    return AnnotationGrounder(str(scenes))


def frame(index: int) -> tuple[np.ndarray, dict]:  # type: ignore[type-arg]
    return render_scene(index, seed=0, size=SIZE)


def labels_of(doc: dict) -> list[str]:  # type: ignore[type-arg]
    return sorted(a["label"] for a in doc["annotations"])


async def test_ground_finds_the_annotated_object_by_a_loose_description(
    grounder: AnnotationGrounder,
) -> None:
    image, doc = frame(1)
    label = doc["annotations"][0]["label"]
    result = await grounder.ground(image, f"the {label} on the table please")
    assert [t.label for t in result.targets] == [label]
    x, y, w, h = doc["annotations"][0]["bbox"]
    assert result.targets[0].box == (x, y, x + w, y + h)
    assert result.targets[0].confidence == 1.0
    assert "scene_0001" in result.reasoning


async def test_point_returns_one_point_per_instance_on_the_object(
    grounder: AnnotationGrounder,
) -> None:
    image, doc = frame(2)
    targets = await grounder.point(image, "every object")
    assert sorted(t.label for t in targets) == labels_of(doc)
    masks = {a["label"]: a for a in doc["annotations"]}
    for t in targets:
        x, y, w, h = masks[t.label]["bbox"]
        (px, py) = t.points[0]
        assert x <= px < x + w
        assert y <= py < y + h


async def test_a_resized_frame_is_recognised_and_boxes_are_scaled(
    grounder: AnnotationGrounder,
) -> None:
    image, doc = frame(3)
    big = np.asarray(cv2.resize(image, (320, 240), interpolation=cv2.INTER_LINEAR), np.uint8)
    targets = await grounder.point(big, "everything")
    assert sorted(t.label for t in targets) == labels_of(doc)
    ann = doc["annotations"][0]
    target = next(t for t in targets if t.label == ann["label"])
    x, _y, w, _h = ann["bbox"]
    assert target.box is not None
    assert abs(target.box[0] - 2 * x) <= 2
    assert abs(target.box[2] - 2 * (x + w)) <= 2


async def test_a_crop_of_a_stored_frame_is_located_and_answered_in_crop_pixels(
    grounder: AnnotationGrounder,
) -> None:
    image, doc = frame(0)
    x0, y0 = 40, 30
    crop = np.ascontiguousarray(image[y0 : y0 + 80, x0 : x0 + 110])
    targets = await grounder.point(crop, "every object")
    expected = [
        a
        for a in doc["annotations"]
        if a["bbox"][0] < x0 + 110
        and a["bbox"][0] + a["bbox"][2] > x0
        and a["bbox"][1] < y0 + 80
        and a["bbox"][1] + a["bbox"][3] > y0
    ]
    assert {t.label for t in targets} <= {a["label"] for a in expected}
    assert targets
    for t in targets:
        assert t.box is not None
        assert 0 <= t.box[0] < t.box[2] <= 110
        assert 0 <= t.box[1] < t.box[3] <= 80


async def test_an_unknown_frame_gets_no_targets_and_an_honest_answer(
    grounder: AnnotationGrounder,
) -> None:
    noise = np.random.default_rng(1).integers(0, 255, (120, 160, 3), dtype=np.uint8)
    result = await grounder.ground(noise, "the red mug", [SemanticRequest("found", "boolean")])
    assert result.targets == []
    assert "not one of the 6 annotated frames" in result.answer
    assert await grounder.point(np.zeros((50, 50, 3), np.uint8), "anything") == []


async def test_semantic_outputs_are_answered_from_the_annotation(
    grounder: AnnotationGrounder,
) -> None:
    image, doc = frame(4)
    label = doc["annotations"][0]["label"]
    outputs = [
        SemanticRequest("found", "boolean", "whether it is visible"),
        SemanticRequest("count", "number"),
        SemanticRequest("objects", "list"),
        SemanticRequest("scene", "text"),
        SemanticRequest("where", "position"),
        SemanticRequest("grasp", "pose"),
        SemanticRequest("elephants", "boolean", "whether a purple elephant is visible"),
    ]
    result = await grounder.ground(image, label, outputs)
    assert result.outputs["found"] is True
    assert result.outputs["count"] == sum(a["label"] == label for a in doc["annotations"])
    assert result.outputs["objects"] == [label] * result.outputs["count"]
    assert result.outputs["scene"] == doc["description"]
    assert set(result.outputs["where"]) == {"x", "y"}
    assert result.outputs["grasp"]["z"] == 0.0
    assert result.outputs["elephants"] is False


async def test_an_output_naming_an_object_is_matched_against_its_own_description(
    grounder: AnnotationGrounder,
) -> None:
    image, doc = frame(4)
    absent = next(
        lb
        for lb in (
            "red mug",
            "blue box",
            "scissors",
            "white plate",
            "green bottle",
            "yellow package",
        )
        if lb not in labels_of(doc)
    )
    present = doc["annotations"][0]["label"]
    outputs = [
        SemanticRequest("has_present", "boolean", f"whether a {present} is visible"),
        SemanticRequest("has_absent", "boolean", f"whether a {absent} is visible"),
    ]
    result = await grounder.ground(image, "describe the table", outputs, mode="describe")
    assert result.outputs == {"has_present": True, "has_absent": False}
    assert result.answer == doc["description"]
    assert result.targets == []


async def test_describe_mode_counts_every_object(grounder: AnnotationGrounder) -> None:
    image, doc = frame(5)
    result = await grounder.ground(
        image,
        "what is on the table",
        [SemanticRequest("n", "number"), SemanticRequest("o", "list")],
        mode="describe",
    )
    assert result.outputs["n"] == len(doc["annotations"])
    assert sorted(result.outputs["o"]) == labels_of(doc)


async def test_region_mode_returns_free_space_clear_of_every_object(
    grounder: AnnotationGrounder,
) -> None:
    image, doc = frame(1)
    result = await grounder.ground(image, "free space for the package", mode="region")
    [region] = result.targets
    assert region.kind == "region"
    assert region.box is not None
    rx0, ry0, rx1, ry1 = region.box
    assert (rx1 - rx0) * (ry1 - ry0) > 0
    for a in doc["annotations"]:
        x, y, w, h = a["bbox"]
        assert rx1 <= x or x + w <= rx0 or ry1 <= y or y + h <= ry0


async def test_a_query_naming_nothing_present_finds_nothing(grounder: AnnotationGrounder) -> None:
    image, _ = frame(1)
    result = await grounder.ground(image, "the purple elephant")
    assert result.targets == []
    assert "nothing matches" in result.answer


def test_a_missing_or_empty_directory_is_a_clear_error(tmp_path: Path) -> None:
    with pytest.raises(ModelUnavailableError, match="does not exist"):
        AnnotationGrounder(str(tmp_path / "nope"))
    (tmp_path / "other.json").write_text(json.dumps({"not": "an annotation"}))
    (tmp_path / "broken.json").write_text("{")
    with pytest.raises(ModelUnavailableError, match="sample_scenes"):
        AnnotationGrounder(str(tmp_path))


def test_an_annotation_without_its_image_is_a_clear_error(tmp_path: Path) -> None:
    generate_scenes(tmp_path, count=1, size=SIZE)
    (tmp_path / "scene_0000.png").unlink()
    with pytest.raises(ValueError, match="missing or unreadable"):
        AnnotationGrounder(str(tmp_path))


def test_a_malformed_annotation_entry_is_a_clear_error(tmp_path: Path) -> None:
    generate_scenes(tmp_path, count=1, size=SIZE)
    path = tmp_path / "scene_0000.json"
    doc = json.loads(path.read_text())
    doc["annotations"][0].pop("label")
    path.write_text(json.dumps(doc))
    with pytest.raises(ValueError, match="bad annotation"):
        AnnotationGrounder(str(tmp_path))


def test_an_annotation_with_only_a_bbox_is_used_as_a_box(tmp_path: Path) -> None:
    generate_scenes(tmp_path, count=1, size=SIZE)
    path = tmp_path / "scene_0000.json"
    doc = json.loads(path.read_text())
    for a in doc["annotations"]:
        a["segmentation"] = []
        a.pop("area")
    path.write_text(json.dumps(doc))
    grounder = AnnotationGrounder(str(tmp_path))
    assert grounder.index.frames[0].objects[0].area > 0


def test_label_matching_is_tolerant_but_not_careless() -> None:
    assert label_score("the red mug on the left", "red mug") == 2
    assert label_score("a cup", "red mug") == 1
    assert label_score("the blue mug", "red mug") == 0
    assert label_score("boxes", "blue box") == 1
    assert label_score("the scissors lying on top of the pile", "scissors") == 1
    assert label_score("the biggest packages", "yellow package") == 1
    assert tokens("Bottles, batteries and glass") == ["bottle", "battery", "and", "glass"]
    assert is_generic("every distinct object")
    assert is_generic("")
    assert not is_generic("mug")


def test_spatial_words_pick_one_instance() -> None:
    items = [("mug", (10.0, 50.0), 5.0), ("mug", (90.0, 10.0), 9.0), ("box", (50.0, 90.0), 1.0)]

    def pick(query: str) -> list[tuple[str, tuple[float, float], float]]:
        return select(query, items, lambda i: i[0], lambda i: i[1], lambda i: i[2])

    assert pick("the mug on the left") == [items[0]]
    assert pick("the right mug") == [items[1]]
    assert pick("top mug") == [items[1]]
    assert pick("bottom mug") == [items[0]]
    assert pick("biggest mug") == [items[1]]
    assert pick("smallest mug") == [items[0]]
    assert pick("mugs") == items[:2]
    assert pick("the leftmost object") == [items[0]]


def test_free_space_is_the_largest_rectangle_clear_of_obstacles() -> None:
    assert largest_free_rect(80, 40, [], margin_px=0) == (0, 0, 80, 40)
    rect = largest_free_rect(80, 40, [(0, 0, 40, 40)], margin_px=0)
    assert rect == (40, 0, 80, 40)
    assert largest_free_rect(80, 40, [(0, 0, 80, 40)], margin_px=0) is None


async def test_a_frame_added_to_the_folder_while_running_is_answered(tmp_path: Path) -> None:
    """The contract with robot-sim: a frame saved (image, then JSON) before it is published
    is recognised on its first lookup, without restarting the grounder."""
    generate_scenes(tmp_path, count=2, seed=0, size=SIZE)
    grounder = AnnotationGrounder(str(tmp_path))
    later, doc = render_scene(5, seed=0, size=SIZE)
    before = await grounder.ground(later, "anything", mode="describe")
    assert "not one of the 2 annotated frames" in before.answer
    cv2.imwrite(str(tmp_path / "late.png"), cv2.cvtColor(later, cv2.COLOR_RGB2BGR))
    doc["image"]["file_name"] = "late.png"
    (tmp_path / "late.json").write_text(json.dumps(doc))
    after = await grounder.ground(later, labels_of(doc)[0])
    assert {t.label for t in after.targets} == {labels_of(doc)[0]}
    assert len(grounder.index.frames) == 3
    assert grounder.index.refresh() == 0  # nothing new: no re-read


def test_a_half_written_frame_is_skipped_until_its_image_is_there(tmp_path: Path) -> None:
    generate_scenes(tmp_path, count=1, seed=0, size=SIZE)
    grounder = AnnotationGrounder(str(tmp_path))
    later, doc = render_scene(3, seed=0, size=SIZE)
    doc["image"]["file_name"] = "late.png"
    (tmp_path / "late.json").write_text(json.dumps(doc))
    (tmp_path / "notes.json").write_text(json.dumps({"not": "an annotation"}))
    assert grounder.index.refresh() == 0
    cv2.imwrite(str(tmp_path / "late.png"), cv2.cvtColor(later, cv2.COLOR_RGB2BGR))
    # Make sure the folder's mtime moved even on a coarse-timestamp file system.
    os.utime(tmp_path, ns=(1, tmp_path.stat().st_mtime_ns + 1_000_000))
    assert grounder.index.refresh() == 1


def test_a_frame_its_producer_deleted_is_dropped_from_the_index(tmp_path: Path) -> None:
    """robot-sim keeps a bounded folder (a new frame whenever the robot moves): frames it
    deleted leave the index too, so the grounder's memory stays bounded."""
    generate_scenes(tmp_path, count=3, seed=0, size=SIZE)
    grounder = AnnotationGrounder(str(tmp_path))
    assert len(grounder.index.frames) == 3
    first = sorted(tmp_path.glob("*.json"))[0]
    doc = json.loads(first.read_text())
    image = cv2.cvtColor(cv2.imread(str(tmp_path / doc["image"]["file_name"])), cv2.COLOR_BGR2RGB)
    assert asyncio.run(grounder.ground(image, labels_of(doc)[0])).targets
    first.unlink()  # JSON first, as robot-sim deletes
    (tmp_path / doc["image"]["file_name"]).unlink()
    os.utime(tmp_path, ns=(1, tmp_path.stat().st_mtime_ns + 1_000_000))
    assert grounder.index.refresh() == 0
    assert len(grounder.index.frames) == 2
    assert first not in {f.annotation for f in grounder.index.frames}
    assert not asyncio.run(grounder.ground(image, labels_of(doc)[0])).targets
