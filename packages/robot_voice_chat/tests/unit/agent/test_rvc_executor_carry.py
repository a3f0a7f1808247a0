"""Fetch, pick, put and hand over on the rules planner over the simulated office with an arm:
the thing leaves its place and arrives where it was brought (read from the office's world, not
the summary); a failed grasp is retried once; without an arm the robot never claims to carry."""

from __future__ import annotations

from pathlib import Path

from robot_stack_testing import async_wait_until
from robot_stack_testing.brain.fake_wire import anthropic_responder
from robot_stack_testing.brain.office import office
from robot_stack_testing.fake_anthropic import FakeAnthropicApi
from robot_stack_testing.fake_api_server import serve_in_thread
from robot_voice_chat.services.llm.anthropic import AnthropicLLM
from robot_voice_chat.services.llm.rules.planner import RulesPlanner

FETCH = "fetch the package from the mailroom and bring it to reception"


async def test_fetch_picks_carries_places_and_confirms_with_the_camera(tmp_path: Path) -> None:
    o = office(tmp_path, arm=True)
    mission = await o.run(FETCH)
    assert mission.state == "succeeded", mission.summary
    assert o.world.objects["mailroom"] == []
    assert o.world.objects["reception"] == ["yellow package"]
    assert o.world.arm.held is None
    assert mission.summary == (
        "I picked up the yellow package in the mailroom. "
        "I brought the yellow package to the reception: I can see it there."
    )
    picks = o.tools.called("manipulation.pick")
    assert picks[0]["label"] == "yellow package"
    assert picks[0]["mask_ref"]["topic"] == "/vision/find_object/detections"
    assert o.tools.called("manipulation.get_held")  # what is held was read back
    assert [a["location"] for a in o.tools.called("navigation.navigate_to")][-1] == "reception"
    titles = [s.title for s in mission.steps]
    assert "Pick up the package" in titles
    assert "Put the package down" in titles
    assert "Look that it is there" in titles
    statuses = o.statuses(mission)
    assert statuses.pop("s1") == "failed"  # the closed mailroom door; then the detour
    assert set(statuses.values()) == {"succeeded"}, statuses


async def test_a_failed_grasp_is_retried_once_after_a_fresh_look(tmp_path: Path) -> None:
    o = office(tmp_path, arm=True)
    o.world.door_closed = False
    o.world.arm.fail_grasps = 1
    mission = await o.run(FETCH)
    assert mission.state == "succeeded", mission.summary
    assert len(o.tools.called("manipulation.pick")) == 2
    assert o.world.objects["reception"] == ["yellow package"]
    assert any("try once more" in line for line in o.speech.spoken)
    statuses = o.statuses(mission)
    assert "failed" in statuses.values()  # the first grasp stays failed in the plan


async def test_two_failed_grasps_end_with_the_truth_and_the_package_where_it_is(
    tmp_path: Path,
) -> None:
    o = office(tmp_path, arm=True)
    o.world.door_closed = False
    o.world.arm.fail_grasps = 2
    mission = await o.run(FETCH)
    assert mission.state == "failed"
    assert len(o.tools.called("manipulation.pick")) == 2
    assert mission.summary == (
        "I couldn't pick up the package: the grasp didn't hold (I tried twice). "
        "It is still in the mailroom."
    )
    assert o.world.objects["mailroom"] == ["yellow package"]
    assert "reception" not in [a["location"] for a in o.tools.called("navigation.navigate_to")]
    assert "GRASP" not in mission.summary


async def test_two_failed_grasps_where_it_stands_say_where_the_thing_is(tmp_path: Path) -> None:
    # no place was named: the sentence ends with where it saw it, never "It is still."
    o = office(tmp_path, arm=True)
    o.world.at = "kitchen"
    o.world.arm.fail_grasps = 2
    mission = await o.run("pick up the red mug")
    assert mission.state == "failed"
    assert mission.summary == (
        "I couldn't pick up the red mug: the grasp didn't hold (I tried twice). "
        "It is still where I saw it."
    )
    assert o.world.arm.held is None


async def test_without_an_arm_the_robot_finds_it_and_says_it_cannot_carry_it(
    tmp_path: Path,
) -> None:
    o = office(tmp_path)
    o.world.door_closed = False
    mission = await o.run(FETCH)
    assert mission.state == "failed"
    assert mission.summary == (
        "I found the package in the mailroom: yellow package (0.91). But I can't carry it: "
        "I have no arm connected right now. It is still in the mailroom."
    )
    assert [a["location"] for a in o.tools.called("navigation.navigate_to")] == ["mailroom"]
    assert "brought" not in mission.summary
    mission = await o.run("pick up the package")
    assert mission.state == "failed"
    assert "no arm connected" in mission.summary


async def test_pick_up_here_then_put_it_down_elsewhere_and_hand_over(tmp_path: Path) -> None:
    o = office(tmp_path, arm=True)
    o.world.at = "kitchen"
    mission = await o.run("pick up the red mug")
    assert mission.state == "succeeded", mission.summary
    assert mission.summary == "I picked up the red mug. I'm holding it; tell me where to bring it."
    assert o.world.arm.held == "red mug"
    mission = await o.run("put it down at reception")
    assert mission.state == "succeeded", mission.summary
    assert o.world.objects["reception"] == ["red mug"]
    assert mission.summary == "I put the red mug down at the reception: I can see it there."
    mission = await o.run("hand it over")
    assert mission.state == "failed"
    assert mission.summary == "I'm not holding anything."
    assert o.tools.called("manipulation.release") == []


async def test_a_put_the_camera_does_not_confirm_is_not_claimed(tmp_path: Path) -> None:
    o = office(tmp_path, arm=True)
    o.world.at = "kitchen"
    o.world.arm.held = "yellow package"
    o.world.arm.drops = True  # the arm says it put it down; it fell behind the counter
    mission = await o.run("put it down")
    assert mission.state == "failed"
    assert mission.summary == (
        "I put the yellow package down, but the camera doesn't show it there, "
        "so I can't confirm it arrived."
    )
    assert "yellow package" not in o.world.objects["kitchen"]


async def test_the_claude_planner_runs_the_fetch_through_the_strict_fake_api(
    tmp_path: Path,
) -> None:
    """The Anthropic adapter (a stand-in model behind the strict fake Messages API) gets the
    arm's tools, passes the mask_ref through unchanged, and the package arrives."""
    fake = FakeAnthropicApi(anthropic_responder(RulesPlanner()))
    with serve_in_thread(fake.app()) as url:
        o = office(tmp_path, arm=True)
        o.world.door_closed = False
        planner = AnthropicLLM(api_key="k", base_url=url, max_retries=0, request_timeout_s=10)
        o.executor.planner = planner
        mission = await o.run(FETCH, timeout_s=30.0)
        await planner.aclose()
    assert mission.state == "succeeded", mission.summary
    assert not fake.rejections, fake.rejections
    tools = {t["name"] for t in fake.requests[0]["tools"]}
    assert {"manipulation__pick", "manipulation__place", "manipulation__get_held"} <= tools
    assert "manipulation" in fake.requests[0]["system"][0]["text"]  # the prompt explains them
    assert o.world.objects["reception"] == ["yellow package"]
    assert o.world.objects["mailroom"] == []
    [pick] = o.tools.called("manipulation.pick")
    assert pick["mask_ref"]["topic"] == "/vision/find_object/detections"


async def test_a_stop_mid_pick_cancels_the_arm_and_abort_claims_nothing(tmp_path: Path) -> None:
    o = office(tmp_path, arm=True)
    o.world.door_closed = False
    o.world.arm.act_s = 30.0  # a slow grasp: the stop lands while the arm works
    mission = await o.executor.start(FETCH)
    await async_wait_until(lambda: o.tools.called("manipulation.pick"), 10, "the pick running")
    await o.executor.on_user_turn("stop")
    assert mission.state == "paused"
    assert o.tools.called("manipulation.stop_manipulation") == [{}]  # the arm's stop tool
    assert o.world.tasks["manip-1"]["state"] == "cancelled"
    await o.executor.on_user_turn("abort")
    await o.executor.wait_idle(10)
    assert mission.state == "failed"
    assert "brought" not in mission.summary
    assert o.world.objects["mailroom"] == ["yellow package"]
    assert o.world.arm.held is None
