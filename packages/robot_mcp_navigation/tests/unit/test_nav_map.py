"""The map files navigation ships and tests with (the format's own tests: robot_site_map)."""

from pathlib import Path

from robot_mcp_navigation.config import default_map_path
from robot_mcp_navigation.map import load_map

CLOSED_DOOR_MAP = Path(__file__).parents[1] / "maps" / "office_closed_door.yaml"
"""The office places with a scripted closed mailroom door (the in-process simulated base)."""


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
