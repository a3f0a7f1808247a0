from pathlib import Path

import pytest

from robot_mcp_navigation.config import default_map_path
from robot_mcp_navigation.map import MapError, load_map, normalize_name, parse_map

CLOSED_DOOR_MAP = Path(__file__).parents[1] / "maps" / "office_closed_door.yaml"
"""The office places with a scripted closed mailroom door (the in-process simulated base)."""


MINIMAL = {
    "start": "dock",
    "locations": {"dock": {"x": 0, "y": 0}, "kitchen": {"x": 3, "y": 4, "aliases": ["Tea Room"]}},
}


def test_office_map_has_the_mailroom_scenario_locations_and_no_scripted_failure() -> None:
    nav_map = load_map(default_map_path())

    assert {"dock", "kitchen", "mailroom", "reception", "corridor_b"} <= set(nav_map.locations)
    assert nav_map.start == "dock"
    assert nav_map.failures == []


def test_the_test_map_scripts_a_once_door_failure_for_the_simulated_base() -> None:
    nav_map = load_map(CLOSED_DOOR_MAP)

    (door,) = nav_map.failures
    assert (door.location, door.error_code, door.mode) == ("mailroom", "DOOR_CLOSED", "once")
    assert door.recoverable
    assert any("corridor_b" in s for s in door.suggestions)
    assert any("open" in s for s in door.suggestions)


def test_missing_map_file_is_a_map_error_naming_the_path(tmp_path: Path) -> None:
    missing = tmp_path / "nope.yaml"

    with pytest.raises(MapError, match=r"nope\.yaml"):
        load_map(missing)


def test_broken_yaml_is_a_map_error(tmp_path: Path) -> None:
    path = tmp_path / "bad.yaml"
    path.write_text("locations: [unclosed\n")

    with pytest.raises(MapError, match="not valid YAML"):
        load_map(path)


def test_a_failure_on_an_unknown_location_is_rejected_with_its_name() -> None:
    data = {**MINIMAL, "failures": [{"location": "attic", "error_code": "X", "message": "m"}]}

    with pytest.raises(MapError, match="attic"):
        parse_map(data)


def test_start_must_be_one_of_the_locations() -> None:
    with pytest.raises(MapError, match="start"):
        parse_map({**MINIMAL, "start": "garage"})


def test_bad_field_values_are_reported_with_their_path() -> None:
    with pytest.raises(MapError, match=r"speed_mps"):
        parse_map({**MINIMAL, "speed_mps": -1})


def test_a_map_that_is_not_a_mapping_is_rejected() -> None:
    with pytest.raises(MapError, match="mapping"):
        parse_map(["dock"])


def test_location_names_must_be_snake_case() -> None:
    with pytest.raises(MapError, match="lower-case"):
        parse_map({"start": "Dock", "locations": {"Dock": {"x": 0, "y": 0}}})


def test_an_alias_may_name_only_one_location() -> None:
    data = {
        "start": "dock",
        "locations": {
            "dock": {"x": 0, "y": 0, "aliases": ["kitchen"]},
            "kitchen": {"x": 1, "y": 1},
        },
    }

    with pytest.raises(MapError, match="alias"):
        parse_map(data)


def test_locations_resolve_case_insensitively_and_by_alias() -> None:
    nav_map = parse_map(MINIMAL)

    assert nav_map.resolve("  Kitchen ") == "kitchen"
    assert nav_map.resolve("tea-room") == "kitchen"
    assert nav_map.resolve("garage") is None
    assert normalize_name("Front Desk") == "front_desk"


def test_without_failures_keeps_locations_and_drops_failures() -> None:
    nav_map = load_map(CLOSED_DOOR_MAP)

    plain = nav_map.without_failures()

    assert plain.failures == []
    assert plain.locations == nav_map.locations
