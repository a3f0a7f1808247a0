"""Multi-leg requests (issue 22) through the whole executor on the rules planner in the
simulated office: every leg in order, each drive only after the last one arrived."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from robot_stack_testing.brain.office import Office, office


def _record_where_each_drive_starts(o: Office) -> list[tuple[str, str]]:
    """(where the robot stood, where it was sent) for every navigate_to, in order."""
    starts: list[tuple[str, str]] = []
    navigate = o.world.navigate_to

    def recording(args: dict[str, Any]) -> dict[str, Any]:
        starts.append((o.world.at, str(args.get("location"))))
        return navigate(args)

    o.tools.add("navigation.navigate_to", recording, location="string", triggers="array")
    return starts


async def test_a_sequence_drives_every_leg_in_order_after_each_arrival(tmp_path: Path) -> None:
    o = office(tmp_path)
    starts = _record_where_each_drive_starts(o)
    mission = await o.run("go to the kitchen and then to reception")
    assert mission.state == "succeeded", mission.summary
    assert starts == [("dock", "kitchen"), ("kitchen", "reception")]
    assert o.world.at == "reception"
    assert [t["state"] for t in o.world.tasks.values()] == ["succeeded", "succeeded"]
    assert not o.tools.called("navigation.stop_navigation")  # no drive cut another short
    assert [s.title for s in mission.steps] == [
        "Drive to the kitchen",
        "Drive to the reception",
        "Tell the user",
    ]
    assert set(o.statuses(mission).values()) == {"succeeded"}
    assert mission.summary == "I'm in the kitchen. I'm at the reception."


async def test_the_summary_names_places_as_the_map_describes_them(tmp_path: Path) -> None:
    o = office(tmp_path)
    described = {"kitchen": "Kitchen with the coffee machine.", "reception": "Reception desk."}
    listed = o.world.list_locations({})
    for location in listed["locations"]:
        location["description"] = described.get(location["name"], "")
    o.tools.add("navigation.list_locations", lambda _args: listed)
    mission = await o.run("go to the kitchen and then to reception")
    assert mission.state == "succeeded", mission.summary
    assert mission.summary == "I'm in the kitchen. I'm at the reception desk."


async def test_three_legs_with_then_and_commas_keep_their_order(tmp_path: Path) -> None:
    o = office(tmp_path)
    starts = _record_where_each_drive_starts(o)
    mission = await o.run("Go to reception, then the kitchen, then back to the dock")
    assert mission.state == "succeeded", mission.summary
    assert [to for _, to in starts] == ["reception", "kitchen", "dock"]
    assert [at for at, _ in starts] == ["dock", "reception", "kitchen"]


async def test_fetch_and_deliver_finds_it_there_then_brings_it(tmp_path: Path) -> None:
    o = office(tmp_path, arm=True)
    starts = _record_where_each_drive_starts(o)
    mission = await o.run("fetch the package from the mailroom and bring it to reception")
    assert mission.state == "succeeded", mission.summary
    # the closed door is passed by the suggested detour; the delivery waits for the find
    assert [to for _, to in starts] == ["mailroom", "corridor_b", "mailroom", "reception"]
    assert starts[-1][0] == "mailroom"
    queries = o.tools.called("skill_control.instantiate_skill")
    # the look before the pick, and the look that confirms it arrived
    assert [q["params"] for q in queries] == [{"query": "package"}, {"query": "yellow package"}]
    names = [name for name, _ in o.tools.calls]
    assert names.index("manipulation.pick") < len(names) - 1 - names[::-1].index(
        "navigation.navigate_to"
    )
    assert mission.summary == (
        "I picked up the yellow package in the mailroom. "
        "I brought the yellow package to the reception: I can see it there."
    )
    assert o.world.at == "reception"


async def test_a_fetch_that_finds_nothing_delivers_nothing(tmp_path: Path) -> None:
    o = office(tmp_path)
    mission = await o.run("pick up the stapler in the kitchen and bring it to reception")
    assert mission.state == "failed"
    assert mission.summary == "I couldn't see the stapler in the kitchen."
    drives = [a["location"] for a in o.tools.called("navigation.navigate_to")]
    assert drives == ["kitchen"]


async def test_an_unknown_place_in_a_later_leg_stops_before_the_first_drive(
    tmp_path: Path,
) -> None:
    o = office(tmp_path)
    mission = await o.run("go to the kitchen and then to the moon")
    assert mission.state == "failed"
    assert not o.tools.called("navigation.navigate_to")
    assert "moon" in mission.summary


async def test_a_delivery_to_an_unknown_place_is_asked_about_not_driven(tmp_path: Path) -> None:
    o = office(tmp_path)
    mission = await o.run("fetch the red mug from the kitchen and bring it to the moon")
    assert mission.state == "failed"
    assert not o.tools.called("navigation.navigate_to")
    assert "I don't know a place called 'moon'" in mission.summary
    # what it offers to do instead leaves the unknown delivery out
    assert "Do you want me to just get the red mug from the kitchen?" in mission.summary


async def test_two_things_to_find_in_one_place_take_one_drive(tmp_path: Path) -> None:
    """Issue 32: "look for the scissors and the red mug in the kitchen" drives there once and
    looks twice."""
    o = office(tmp_path)
    starts = _record_where_each_drive_starts(o)
    mission = await o.run("look for the scissors and the red mug in the kitchen")
    assert mission.state == "succeeded", mission.summary
    assert starts == [("dock", "kitchen")]
    titles = [s.title for s in mission.steps]
    assert titles.count("Drive to the kitchen") == 1
    assert titles.count("Look for the scissors") == titles.count("Look for the red mug") == 1
    assert mission.summary.startswith("I found the scissors in the kitchen")
    assert "I found the red mug in the kitchen" in mission.summary
