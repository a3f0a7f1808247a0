"""The robot always knows what it holds, and says it (issue 39 item 3), and names the part a lost
motion server leaves stopped (item 2). On the rules planner over the simulated office with an
arm: each claim is checked against the office's world (what the gripper holds, where things
and the robot are), not against the summary alone."""

from __future__ import annotations

import asyncio
import json
from pathlib import Path
from typing import Any

import pytest

from robot_language.scoring import OFFICE_LOCATIONS
from robot_stack_testing import async_wait_until
from robot_stack_testing.brain.office import Office, office
from robot_voice_chat.agent import holding
from robot_voice_chat.agent.holding import CANT_TELL, HeldAtStart, picked_last, tell_what_is_held
from robot_voice_chat.agent.mission import PlanStep
from robot_voice_chat.agent.supervision_words import held_part, lost_motion_server
from robot_voice_chat.held_words import (
    Held,
    held_from,
    names_it,
    still_holding,
    whereabouts_of,
    without_false_places,
)
from robot_voice_chat.robot_words import check_robot_words
from robot_voice_chat.services.emitter.base import FakeEventEmitter
from robot_voice_chat.services.speech.fake import FakeSpeechOutput
from robot_voice_chat.services.tools.fake import FakeToolBackend
from robot_voice_chat.socket_events import ChatMessage

FETCH = "fetch the package from the mailroom and bring it to reception"
QUESTION = "Should I put it down here, or take it somewhere?"


def arm_office(tmp_path: Path) -> Office:
    o = office(tmp_path, arm=True)
    o.world.door_closed = False
    o.world.distances = True  # list_locations gives each place's distance, as the server does
    return o


def carrying(o: Office) -> bool:
    """The package in the gripper and the drive to reception under way."""
    drive = o.world.driving
    return o.world.arm.held is not None and drive is not None and not drive.done()


# --- a failed carry, a stop and an abort: the words name what is held and where ---------------
async def test_a_failed_carry_says_what_the_gripper_holds_and_where_the_robot_is(
    tmp_path: Path,
) -> None:
    o = arm_office(tmp_path)
    o.world.unreachable = {"reception"}  # no way through to reception

    mission = await o.run(FETCH)

    assert mission.state == "failed"
    assert o.world.arm.held == "yellow package"  # the world: in the gripper, in the mailroom
    assert o.world.at == "mailroom"
    assert mission.summary.endswith(
        f"I'm still holding the yellow package, here in the mailroom. {QUESTION}"
    ), mission.summary
    assert "is still in" not in mission.summary
    assert " ".join(o.speech.spoken).endswith(mission.summary)  # said as it is shown


async def test_stop_then_abort_while_carrying_names_the_held_package_and_where(
    tmp_path: Path,
) -> None:
    o = arm_office(tmp_path)
    o.world.drive_times["reception"] = 30.0
    mission = await o.executor.start(FETCH)

    await async_wait_until(lambda: carrying(o), 20, "the carry under way")
    await o.executor.on_user_turn("stop")
    await o.executor.on_user_turn("abort")
    await o.executor.wait_idle(10)

    assert mission.state == "failed"
    assert o.world.arm.held == "yellow package"  # the world: still in the gripper, on the way
    assert o.world.off_m > 0
    assert mission.summary == (
        "Stopped by the user; mission aborted. I'm still holding the yellow package, near "
        f"the mailroom. {QUESTION}"
    )


async def test_an_abort_while_carrying_names_the_held_package_and_where(tmp_path: Path) -> None:
    """The abort heard at once (no stop first) ends the carry; its end is told with the
    gripper's word."""
    o = arm_office(tmp_path)
    o.world.drive_times["reception"] = 30.0
    mission = await o.executor.start(FETCH)
    await async_wait_until(lambda: carrying(o), 20, "the carry under way")

    await o.executor.on_user_turn("abort")
    await o.executor.wait_idle(10)

    assert mission.state in ("cancelled", "failed")
    assert o.world.arm.held == "yellow package"
    assert o.world.off_m > 0  # the drive was stopped on its way
    assert "I'm still holding the yellow package, near the mailroom." in mission.summary


# --- a pick reported lost after the grasp: the words follow get_held --------------------------
async def test_a_pick_lost_to_a_server_restart_after_the_grasp_goes_on_with_what_is_held(
    tmp_path: Path,
) -> None:
    """kill -9 of the arm server during the pick, the grasp finished all the same: the
    restarted server reports the pick lost, the gripper holds it — the robot carries it on,
    never "It is still in the mailroom"."""
    o = arm_office(tmp_path)
    o.world.arm.lost_after_grasp = True

    mission = await o.run(FETCH)

    assert mission.state == "succeeded", mission.summary
    assert o.world.objects["reception"] == ["yellow package"]
    assert o.world.arm.held is None
    assert "still in the mailroom" not in mission.summary
    assert len(o.tools.called("manipulation.pick")) == 1


async def test_a_pick_cut_off_by_the_arm_servers_death_is_told_and_claims_nothing(
    tmp_path: Path,
) -> None:
    """kill -9 of the arm server while the pick call was out (it may have started the arm):
    the robot says it lost contact with its arm at once, and the summary does not claim where
    the package is — nobody can know until the arm answers again."""
    o = arm_office(tmp_path)
    o.world.arm.cut_off_pick = True

    mission = await o.run(FETCH)

    assert mission.state == "failed"
    said = " ".join(o.speech.spoken)
    assert "I lost contact with my arm" in said, said
    assert mission.summary.startswith(
        "I couldn't pick up the package: I lost contact with my arm while it was starting. "
        "I can't tell yet whether my gripper closed on it."
    ), mission.summary
    assert "still in the mailroom" not in mission.summary
    assert "reported a problem" not in mission.summary
    assert check_robot_words([said, mission.summary]) == []


async def test_a_failed_put_says_what_the_gripper_says_not_that_it_still_holds_it(
    tmp_path: Path,
) -> None:
    o = arm_office(tmp_path)
    o.world.arm.lost_on_place = True  # the gripper opened; the package fell out of reach

    mission = await o.run(FETCH)

    assert mission.state == "failed"
    assert o.world.arm.held is None
    assert "yellow package" not in o.world.objects["reception"]
    assert mission.summary.endswith(
        "My gripper is empty now, but I can't confirm where it went."
    ), mission.summary
    assert "I still hold it" not in mission.summary


# --- a search for what the gripper holds is answered from the gripper --------------------------
async def test_a_search_for_the_held_package_is_answered_from_the_gripper(tmp_path: Path) -> None:
    o = arm_office(tmp_path)
    o.world.arm.held = "yellow package"
    o.world.objects["mailroom"].remove("yellow package")
    o.world.at = "corridor_b"

    mission = await o.run("find the yellow package in the mailroom")

    assert mission.state == "succeeded", mission.summary
    assert mission.summary == "I'm holding the yellow package."
    assert o.tools.called("navigation.navigate_to") == []  # no drive, no look
    assert o.tools.called("skill_control.instantiate_skill") == []


async def test_a_fetch_of_the_held_package_only_delivers_it(tmp_path: Path) -> None:
    o = arm_office(tmp_path)
    o.world.arm.held = "yellow package"
    o.world.objects["mailroom"].remove("yellow package")
    o.world.at = "kitchen"

    mission = await o.run(FETCH)

    assert mission.state == "succeeded", mission.summary
    assert o.world.objects["reception"] == ["yellow package"]
    assert o.world.arm.held is None
    assert [a["location"] for a in o.tools.called("navigation.navigate_to")] == ["reception"]
    assert o.tools.called("manipulation.pick") == []
    assert mission.summary.startswith("I already have the yellow package. I brought")


# --- the end of a mission, over the tool port ---------------------------------------------------
def backend(held: dict[str, Any] | None, distances: dict[str, float] | None) -> FakeToolBackend:
    tools = FakeToolBackend()
    if held is not None:
        tools.add("manipulation.get_held", lambda a: held)
    if distances is not None:
        locations = [
            {**place, "distance_m": distances.get(place["name"], 30.0)}
            for place in OFFICE_LOCATIONS
        ]
        tools.add("navigation.list_locations", lambda a: {"locations": locations})
    return tools


async def test_the_end_of_any_mission_tells_the_held_thing_with_the_nearest_place() -> None:
    tools = backend({"known": True, "holding": True, "label": "yellow package"},
                    {"corridor_b": 2.5, "mailroom": 4.0})  # fmt: skip
    summary = (
        "I couldn't pick up the package: my arm reported a problem. It is still in the mailroom."
    )

    told = await tell_what_is_held(tools, summary)

    assert told == (
        "I couldn't pick up the package: my arm reported a problem. I'm still holding the "
        f"yellow package, near the east corridor. {QUESTION}"
    )
    assert not check_robot_words([told])


@pytest.mark.parametrize(
    ("held", "summary"),
    [
        (None, "The mission was aborted."),  # no arm: nothing read, nothing said
        ({"known": True, "holding": False, "label": None}, "The mission was aborted."),
        ({"known": False, "holding": False}, "The mission was aborted."),
        (
            {"known": True, "holding": True, "label": "red mug"},
            "I couldn't put the red mug down at reception: no free surface. I still hold it.",
        ),
    ],
)
async def test_nothing_is_added_without_a_held_thing_or_when_the_summary_says_it(
    held: dict[str, Any] | None, summary: str
) -> None:
    assert await tell_what_is_held(backend(held, {"dock": 0.0}), summary) == summary


def gone(args: dict[str, Any]) -> Any:
    raise ValueError("error: server 'manipulation' is not connected")


async def test_an_arm_that_does_not_answer_adds_nothing() -> None:
    tools = FakeToolBackend()
    tools.add("manipulation.get_held", gone)
    assert await tell_what_is_held(tools, "Stopped.") == "Stopped."


def test_where_the_robot_is_is_the_nearest_named_place() -> None:
    listed = {"locations": [{**p, "distance_m": 9.0} for p in OFFICE_LOCATIONS]}
    listed["locations"][4]["distance_m"] = 0.4  # the mailroom
    assert whereabouts_of(json.dumps(listed)) == "here in the mailroom"
    listed["locations"][4]["distance_m"] = 3.0
    assert whereabouts_of(json.dumps(listed)) == "near the mailroom"
    listed["locations"][1]["distance_m"] = 0.2
    assert whereabouts_of(json.dumps(listed)) == "here at the reception desk"
    assert whereabouts_of(json.dumps({"locations": OFFICE_LOCATIONS})) is None  # no distances
    assert whereabouts_of("not json") is None


def test_the_held_words() -> None:
    assert held_from('{"known": true, "holding": true, "label": "red mug"}', False) == Held(
        True, "red mug"
    )
    assert held_from('{"holding": false, "label": null}', False) == Held(True, None)
    assert held_from("error: server 'manipulation' is not connected", True) == Held(False)
    assert names_it("package", "yellow package")
    assert names_it("the yellow package", "yellow package")
    assert not names_it("red mug", "yellow package")
    assert not names_it("", "yellow package")
    assert (
        without_false_places(
            "I couldn't pick it up. It is still in the mailroom. The red mug is still at Bob's.",
            "yellow package",
        )
        == "I couldn't pick it up. The red mug is still at Bob's."
    )
    assert still_holding("red mug", None) == f"I'm still holding the red mug. {QUESTION}"


# --- item 2: the words name the part a lost server's lock holds ------------------------------
class LapsedSupervisor:
    async def settle(self, server: str) -> tuple[str, float]:
        return "lapsed", 0.0


async def test_a_lost_arm_server_is_said_to_hold_the_arm_not_the_base() -> None:
    said = await lost_motion_server(LapsedSupervisor(), "manipulation")  # type: ignore[arg-type]

    assert "lost contact with my arm" in said
    assert "the robot's arm holds itself stopped" in said
    assert "base" not in said
    nav = await lost_motion_server(LapsedSupervisor(), "navigation")  # type: ignore[arg-type]
    assert "the robot's base holds itself stopped" in nav
    assert held_part({"manipulation", "navigation"}) == "the robot's base and arm"
    assert not check_robot_words([said, nav])


# --- a restart of the brain: the first look at the arm says what it holds ---------------------
async def test_after_a_restart_the_brain_says_what_the_gripper_holds_once(tmp_path: Path) -> None:
    o = arm_office(tmp_path)
    o.world.arm.held = "yellow package"  # what the world holds: a carry a crash cut short
    o.world.at = "mailroom"

    await o.executor.reconcile("navigation")  # not the arm: nothing read yet
    assert o.speech.spoken == []
    await o.executor.reconcile("manipulation")
    await o.executor.reconcile("manipulation")  # a reconnect later: told once per life

    told = f"I'm still holding the yellow package, here in the mailroom. {QUESTION}"
    assert " ".join(o.speech.spoken) == told  # said sentence by sentence
    assert [e.text for e in o.emitter.of(ChatMessage)] == [told]  # type: ignore[attr-defined]
    assert not check_robot_words([told])


@pytest.mark.parametrize(
    "held", [None, {"known": True, "holding": False, "label": None}, {"known": False}]
)
async def test_nothing_is_said_at_start_without_a_held_thing(held: dict[str, Any] | None) -> None:
    speech, emitter = FakeSpeechOutput(), FakeEventEmitter()
    at_start = HeldAtStart(backend(held, {"dock": 0.0}), speech, emitter)
    assert await at_start.on_connect("manipulation", idle=True) is None
    assert speech.spoken == []
    assert emitter.events == []


async def test_at_start_a_navigation_server_still_connecting_is_waited_for_to_say_where() -> None:
    speech, emitter = FakeSpeechOutput(), FakeEventEmitter()
    tools = backend({"known": True, "holding": True, "label": "red mug"}, {"kitchen": 0.4})
    tools.states["navigation"] = "connecting"  # the arm's server answered first
    at_start = HeldAtStart(tools, speech, emitter)

    async def navigation_connects() -> None:
        await asyncio.sleep(0.3)
        tools.states["navigation"] = "connected"

    connecting = asyncio.create_task(navigation_connects())
    told = await at_start.on_connect("manipulation", idle=True)
    await connecting

    assert told == f"I'm still holding the red mug, here in the kitchen. {QUESTION}"


async def test_a_mission_running_at_the_arms_first_connect_tells_it_at_its_end_instead() -> None:
    speech, emitter = FakeSpeechOutput(), FakeEventEmitter()
    tools = backend({"known": True, "holding": True, "label": "red mug"}, {"dock": 0.0})
    at_start = HeldAtStart(tools, speech, emitter)
    assert await at_start.on_connect("manipulation", idle=False) is None
    assert await at_start.on_connect("manipulation", idle=True) is None  # once per life
    assert tools.called("manipulation.get_held") == []


def test_the_last_hand_action_tells_whether_something_may_be_held() -> None:
    def step(tool: str, status: str = "succeeded") -> PlanStep:
        return PlanStep(id=tool, title=tool, tool=tool, status=status)  # type: ignore[arg-type]

    drive = step("navigation.navigate_to")
    assert picked_last([drive, step("manipulation.pick"), drive])
    assert not picked_last([step("manipulation.pick"), step("manipulation.place")])
    assert not picked_last([drive, step("manipulation.pick", "failed")])
    assert not picked_last([drive])


async def test_after_a_pick_an_arm_that_comes_back_is_waited_for(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The arm's server restarting at a mission's end (its carry failed meanwhile): the
    gripper is read once it answers again, not taken as empty."""
    monkeypatch.setattr(holding, "ARM_POLL_S", 0.01)
    answers = iter([None, None])

    def restarting(args: dict[str, Any]) -> Any:
        if next(answers, "back") is None:
            raise ValueError("error: server 'manipulation' is not connected")
        return {"known": True, "holding": True, "label": "yellow package"}

    tools = backend(None, {"mailroom": 1.0})
    tools.add("manipulation.get_held", restarting)
    told = await tell_what_is_held(tools, "I couldn't reach the mailroom.", picked=True)
    assert told.startswith("I couldn't reach the mailroom. I'm still holding the yellow package")


async def test_after_a_pick_a_silent_arm_is_said_so(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(holding, "ARM_POLL_S", 0.01)
    tools = FakeToolBackend()
    tools.add("manipulation.get_held", gone)
    told = await tell_what_is_held(
        tools, "I couldn't reach the mailroom.", picked=True, arm_back_s=0.05
    )
    assert told == f"I couldn't reach the mailroom. {CANT_TELL}"
    assert not check_robot_words([told])
