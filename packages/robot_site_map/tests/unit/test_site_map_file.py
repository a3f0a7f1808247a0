"""The map file format: loading, validation errors that name the file and field, name lookup."""

from pathlib import Path

import pytest

from robot_site_map import (
    FailureSpec,
    Location,
    MapError,
    Pose,
    load_map,
    normalize_name,
    parse_map,
)

MINIMAL = {
    "start": "dock",
    "locations": {"dock": {"x": 0, "y": 0}, "kitchen": {"x": 3, "y": 4, "aliases": ["Tea Room"]}},
}

DOOR_MAP = """\
name: office
speed_mps: 1.2
start: Dock
locations:
  dock: {x: 0, y: 0}
  mailroom: {x: 6.5, y: 4, theta: 1.57, description: parcels}
failures:
  - {location: " MailRoom", error_code: DOOR_CLOSED, message: the door is shut}
"""


def test_a_map_file_loads_with_its_places_speed_and_failures(tmp_path: Path) -> None:
    path = tmp_path / "office.yaml"
    path.write_text(DOOR_MAP)

    nav_map = load_map(path)

    assert (nav_map.name, nav_map.frame, nav_map.speed_mps, nav_map.start) == (
        "office",
        "map",
        1.2,
        "dock",
    )
    assert nav_map.locations["mailroom"].pose() == Pose(6.5, 4.0, 1.57)
    (door,) = nav_map.failures
    assert (door.location, door.mode, door.at_fraction, door.recoverable) == (
        "mailroom",
        "once",
        0.85,
        True,
    )


def test_missing_map_file_is_a_map_error_naming_the_path(tmp_path: Path) -> None:
    missing = tmp_path / "nope.yaml"

    with pytest.raises(MapError, match=r"nope\.yaml"):
        load_map(missing)


def test_an_unreadable_map_path_is_a_map_error(tmp_path: Path) -> None:
    with pytest.raises(MapError, match="cannot read map file"):
        load_map(tmp_path)  # a directory


def test_broken_yaml_is_a_map_error(tmp_path: Path) -> None:
    path = tmp_path / "bad.yaml"
    path.write_text("locations: [unclosed\n")

    with pytest.raises(MapError, match="not valid YAML"):
        load_map(path)


def test_a_failure_on_an_unknown_location_is_rejected_with_its_name() -> None:
    data = {**MINIMAL, "failures": [{"location": "attic", "error_code": "X", "message": "m"}]}

    with pytest.raises(MapError, match="attic"):
        parse_map(data)


def test_a_failure_needs_an_upper_case_code_and_a_fraction_inside_the_drive() -> None:
    with pytest.raises(ValueError, match="error_code"):
        FailureSpec(location="dock", error_code="door_closed", message="m")
    with pytest.raises(ValueError, match="at_fraction"):
        FailureSpec(location="dock", error_code="X", message="m", at_fraction=1.0)


def test_start_must_be_one_of_the_locations() -> None:
    with pytest.raises(MapError, match="start"):
        parse_map({**MINIMAL, "start": "garage"})


def test_bad_field_values_are_reported_with_their_path() -> None:
    with pytest.raises(MapError, match=r"speed_mps"):
        parse_map({**MINIMAL, "speed_mps": -1})


def test_unknown_keys_are_rejected() -> None:
    with pytest.raises(MapError, match="colour"):
        parse_map({**MINIMAL, "colour": "blue"})


def test_errors_name_the_source() -> None:
    with pytest.raises(MapError, match=r"^site\.yaml: invalid map"):
        parse_map({**MINIMAL, "speed_mps": 9}, "site.yaml")


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


def test_without_failures_keeps_locations_and_drops_failures(tmp_path: Path) -> None:
    path = tmp_path / "office.yaml"
    path.write_text(DOOR_MAP)
    nav_map = load_map(path)

    plain = nav_map.without_failures()

    assert plain.failures == []
    assert plain.locations == nav_map.locations
    assert nav_map.failures  # the original is unchanged (frozen)


def test_a_location_is_frozen() -> None:
    place = Location(x=1, y=2)

    with pytest.raises(ValueError, match="frozen"):
        place.x = 3  # type: ignore[misc]
