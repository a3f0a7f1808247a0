"""The world file: the navigation map plus what stands where, validated at start-up."""

from __future__ import annotations

from pathlib import Path

import pytest

from robot_sim.config import default_world_path
from robot_sim.world import World, WorldError, load_world

MAP = (
    Path(__file__).resolve().parents[3] / "robot_mcp_navigation" / "config" / "maps" / "office.yaml"
)
PLAN = default_world_path().parents[1] / "floor" / "office.plan.yaml"


def write_world(tmp_path: Path, body: str) -> Path:
    path = tmp_path / "world.yaml"
    path.write_text(f"map: {MAP}\nfloor: {PLAN}\n{body}")
    return path


def test_the_shipped_world_puts_the_mug_in_the_kitchen_and_the_package_in_the_mailroom() -> None:
    world = load_world(default_world_path())
    assert "red mug" in world.objects_at("kitchen")
    assert "yellow package" in world.objects_at("mailroom")
    assert "red mug" not in world.objects_at("mailroom")
    assert world.objects_at("desk_bob") == ("scissors", "blue folder")
    assert set(world.places) == set(world.map.locations)
    assert world.map.failures == []  # no scripted door: the floor's doors are real
    assert world.closed_doors() == {"mailroom_west_door"}
    assert set(world.doors) == {
        "kitchen_door", "meeting_room_door", "mailroom_west_door", "mailroom_east_entrance",
    }  # fmt: skip


def test_a_place_not_on_the_map_is_refused(tmp_path: Path) -> None:
    path = write_world(
        tmp_path, "objects: {red mug: {shape: mug, colour: [1, 2, 3]}}\nplaces: {attic: {}}\n"
    )
    with pytest.raises(WorldError, match=r"places \['attic'\] are not locations of the map"):
        load_world(path)


def test_an_object_missing_from_the_catalogue_is_refused(tmp_path: Path) -> None:
    path = write_world(
        tmp_path,
        "objects: {red mug: {shape: mug, colour: [1, 2, 3]}}\n"
        "places: {kitchen: {objects: [blue whale]}}\n",
    )
    with pytest.raises(WorldError, match=r"place 'kitchen' lists unknown objects \['blue whale'\]"):
        load_world(path)


@pytest.mark.parametrize(
    ("body", "message"),
    [
        ("objects: {}\n", "objects"),
        ("objects: {x: {shape: cube, colour: [1, 2, 3]}}\n", "shape"),
        ("- a list\n", "must be a YAML mapping"),
        (
            "objects: {x: {shape: mug, colour: [1, 2, 3]}}\ndoors: {back_door: closed}\n",
            "back_door",
        ),
        ("objects: {x: {shape: mug, colour: [1, 2, 3]}}\ndoors: {kitchen_door: ajar}\n", "doors"),
    ],
)
def test_a_bad_world_file_names_the_problem(tmp_path: Path, body: str, message: str) -> None:
    path = tmp_path / "world.yaml"
    path.write_text(body if body.startswith("-") else f"map: {MAP}\nfloor: {PLAN}\n{body}")
    with pytest.raises(WorldError, match=message):
        load_world(path)


def test_missing_files_are_clear_errors(tmp_path: Path) -> None:
    with pytest.raises(WorldError, match="world file not found"):
        load_world(tmp_path / "nope.yaml")
    path = write_world(tmp_path, "objects: {red mug: {shape: mug, colour: [1, 2, 3]}}\n")
    with pytest.raises(WorldError, match="map file not found"):
        load_world(path, tmp_path / "no-map.yaml")
    bad = tmp_path / "bad.yaml"
    bad.write_text("a: [")
    with pytest.raises(WorldError, match="cannot read world file"):
        load_world(bad)


def test_the_map_can_be_given_apart_from_the_world_file() -> None:
    world = load_world(default_world_path(), MAP)
    assert world.map.name == "office"


def test_the_contents_of_a_place_change_and_bad_changes_are_refused() -> None:
    world: World = load_world(default_world_path())
    world.set_objects("kitchen", ["green bottle"])
    assert world.objects_at("kitchen") == ("green bottle",)
    with pytest.raises(WorldError, match="unknown place 'attic'"):
        world.set_objects("attic", [])
    with pytest.raises(WorldError, match="unknown objects"):
        world.set_objects("kitchen", ["unicorn"])
    with pytest.raises(WorldError, match="at most 6 objects"):
        world.set_objects("kitchen", ["red mug"] * 7)
    assert world.objects_at("kitchen") == ("green bottle",)  # nothing lost
    assert world.place("dock").description == "The charging dock's floor plate."


def test_doors_close_and_open_and_an_unknown_door_is_refused() -> None:
    world = load_world(default_world_path())
    version = world.version
    world.set_door("kitchen_door", True)
    assert world.closed_doors() == {"mailroom_west_door", "kitchen_door"}
    world.set_door("mailroom_west_door", False)
    assert world.closed_doors() == {"kitchen_door"}
    assert world.version == version + 2
    with pytest.raises(WorldError, match="unknown door 'cellar'"):
        world.set_door("cellar", True)


def test_a_missing_floor_plan_is_a_clear_error(tmp_path: Path) -> None:
    path = tmp_path / "world.yaml"
    path.write_text(
        f"map: {MAP}\nfloor: gone.yaml\nobjects: {{x: {{shape: mug, colour: [1, 2, 3]}}}}\n"
    )
    with pytest.raises(WorldError, match="floor plan not found"):
        load_world(path)
