"""Name the part that is down (issue 39 item 5): a vision node, perception buffer, arm or base
that does not answer is named in plain words, and "what do you see" with the camera down never
answers with an old sighting as if it were now."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from robot_stack_testing.brain.office import office
from robot_voice_chat.robot_words import check_robot_words
from robot_voice_chat.services.llm.rules.plain import down_sentence, part_down, reason_of

WHAT_HAPPENED = "episodic.what_happened"
# what skill_control answers when the vision node was killed: its call timed out, and the
# detail is the bridge's own text (a ROS service name, the skill's id)
VISION_TIMEOUT = json.dumps(
    {
        "error": "service_timeout",
        "detail": "/vision/create_skill did not answer within 5.0 s; the skill "
        "'find_object_3f2a' did not appear in the node's list either, so it is not running "
        "(if the node creates it late it is removed). Check the vision node and retry.",
    }
)
VISION_GONE = json.dumps(
    {
        "error": "service_unavailable",
        "detail": "no server for /vision/create_skill (is the node running in this ROS domain?)",
    }
)
# the yellow package seen at reception 101 s ago; the robot stands at the dock now
SIGHTING = {
    "items": [
        {
            "kind": "sighting",
            "label": "yellow package",
            "place": "reception",
            "ago": "101 s ago",
            "time": "2026-11-26T15:31:16.000Z",
            "local": "15:31:16 UTC",
        }
    ]
}


def _raises(content: str) -> Any:
    return lambda a: (_ for _ in ()).throw(ValueError(content))


async def test_a_dead_vision_node_at_the_start_of_a_search_is_named(tmp_path: Path) -> None:
    """Was: "I couldn't start looking for the scissors: something went wrong there."."""
    o = office(tmp_path)
    o.tools.add(
        "skill_control.instantiate_skill",
        _raises(VISION_TIMEOUT),
        template="string",
        params="object",
    )
    mission = await o.run("find the scissors in the kitchen")
    assert mission.state == "failed"
    assert mission.summary == (
        "My camera system isn't answering, so I can't look for the scissors right now."
    )
    assert not check_robot_words([mission.summary, *o.speech.spoken])


async def test_a_lost_perception_buffer_is_named_not_taken_for_nothing_seen(
    tmp_path: Path,
) -> None:
    o = office(tmp_path)
    o.tools.add(
        "perception.wait_for_result",
        _raises("error: server 'perception' is not connected"),
        skill="string",
        timeout_s="number",
    )
    o.tools.add("skill_control.list_running_skills", lambda a: {"skills": []})
    mission = await o.run("find the scissors in the kitchen")
    assert mission.state == "failed"
    assert mission.summary == (
        "The part of me that collects what my camera sees isn't answering, so I can't look "
        "for the scissors right now."
    )
    assert "couldn't see" not in mission.summary


@pytest.mark.parametrize("error", [VISION_TIMEOUT, VISION_GONE])
async def test_what_do_you_see_with_the_camera_down_is_honest(tmp_path: Path, error: str) -> None:
    """Was: "I see nothing new right now. The last I saw: the yellow package at the reception
    desk 101 s ago" while the robot stood somewhere else."""
    o = office(tmp_path)
    assert o.world.at == "dock"
    o.tools.add(WHAT_HAPPENED, lambda a: SIGHTING, start="string", kinds="array")
    o.tools.add(
        "skill_control.instantiate_skill", _raises(error), template="string", params="object"
    )
    mission = await o.run("what do you see?")
    summary = mission.summary
    assert mission.state == "failed", summary
    assert summary.startswith("My camera system isn't answering, so I can't look right now.")
    assert not summary.startswith("I see")
    assert "nothing new" not in summary
    # the old sighting is said as old and where it was, never as what is in front of it now
    assert "yellow package" in summary
    assert "101 s ago" in summary
    assert "reception" in summary
    assert not check_robot_words([summary, *o.speech.spoken])


@pytest.mark.parametrize(
    ("content", "part"),
    [
        (VISION_TIMEOUT, "My camera system"),
        (VISION_GONE, "My camera system"),
        ('{"error": "bridge_closed", "detail": "the ROS bridge is closed"}', "My camera system"),
        (
            "error: server 'perception' is not connected",
            "The part of me that collects what my camera sees",
        ),
        ("error: server 'skill_control' is not connected", "The part of me that runs my camera"),
        ("error: server 'manipulation' is not connected", "My arm"),
        ('{"error": "ARM_UNAVAILABLE", "detail": "no arm controller"}', "My arm"),
        ('{"error": "BASE_UNAVAILABLE", "detail": "Nav2 is absent"}', "The robot's base"),
        (
            "error: skill_control.instantiate_skill timed out after 10 s",
            "The part of me that runs my camera",
        ),
        ('{"error": "timeout", "detail": "no result for skill find_object"}', None),
        ('{"error": "DOOR_CLOSED", "detail": "The door is closed."}', None),
    ],
)
def test_each_part_that_does_not_answer_is_named(content: str, part: str | None) -> None:
    assert part_down(content) == part
    if part is not None:
        said = down_sentence(part, "look")
        assert not check_robot_words([said])


def test_the_reasons_for_an_outage_name_the_part() -> None:
    assert reason_of(VISION_TIMEOUT) == "my camera system did not answer in time"
    assert reason_of(VISION_GONE) == "my camera system is not answering"
    assert reason_of('{"error": "ARM_UNAVAILABLE", "detail": "x_y"}') == "my arm is not answering"


async def test_a_buffered_view_is_not_said_as_now_when_the_vision_node_is_gone(
    tmp_path: Path,
) -> None:
    """The e2e run: the vision node killed, "what do you see" answered "I see the charging
    dock's floor plate." from the buffer (warm for its stale window after the node died)."""
    o = office(tmp_path)
    warm = {
        "mode": "warm",
        "age_s": 8.2,
        "stale": False,
        "scene_description": {"value": "The charging dock's floor plate.", "age_s": 8.2},
        "skills": [],
    }
    o.tools.add("perception.what_do_you_see", lambda a: warm)
    o.tools.add("skill_control.list_running_skills", lambda a: {"skills": []})
    mission = await o.run("what do you see?")  # the node answers: the view is what it sees
    assert mission.state == "succeeded", mission.summary
    assert mission.summary == "I see the charging dock's floor plate."
    o.tools.add("skill_control.list_running_skills", _raises(VISION_GONE))
    mission = await o.run("what do you see?")
    assert mission.state == "failed", mission.summary
    assert mission.summary == (
        "My camera system isn't answering, so I can't look right now. The last view I have, "
        "from 8 s ago, showed the charging dock's floor plate."
    )
    assert not check_robot_words([mission.summary])


def test_a_servers_engineering_detail_is_left_out_of_the_reason() -> None:
    failed = json.dumps({
        "error_code": "NO_PATH",
        "message": "Nav2 found no path to the destination (the way may be blocked, e.g. a closed "
        "door) on the way to mailroom (Nav2 error 208: no valid path: the way to the goal is "
        "blocked)",
    })  # fmt: skip
    said = reason_of(failed)
    assert said == "I found no way there (it may be blocked, for example by a closed door)"
    assert not check_robot_words([said])
    assert check_robot_words(["Nav2 found no path to the destination"])  # an engineer's name


def test_a_lost_base_is_said_in_the_robots_words_not_the_navigation_servers() -> None:
    failed = json.dumps({
        "error_code": "BASE_UNAVAILABLE",
        "message": "lost contact with the robot base on the way to kitchen: its navigation stack "
        "sent nothing for 3 s (stopped or restarting)",
    })  # fmt: skip
    said = reason_of(failed)
    assert said == "my base stopped answering"
    assert not check_robot_words([said])
