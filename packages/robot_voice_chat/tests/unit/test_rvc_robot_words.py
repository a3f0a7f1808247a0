"""The robot's words (issue 31): no task ids, tool names, error codes, snake_case ids or raw
server text in what it says or shows, places by their human names, "just now" under a second.

Three layers: the checker itself; every sentence template fed the raw answers real servers
give (codes, tool names and map ids inside); and missions that fail in every way the rules
planner and chat know, collected from what the fakes were asked to say. Beyond this file, every
test of this package has what its scenario made the robot say checked (tests/conftest.py), and
the e2e tests check every reply they see (robot_stack_testing.MissionDriver)."""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from robot_language.places import PlaceIndex
from robot_language.recall import LAST_SEEN, read_recall
from robot_language.scoring import OFFICE_LIST_LOCATIONS
from robot_stack_testing.brain.office import Office, office
from robot_stack_testing.brain.office_world import DOOR_SUGGESTIONS
from robot_voice_chat.agent.abort import aborted_summary, aborting_note, busy_note
from robot_voice_chat.agent.bargein import STOP_QUESTION
from robot_voice_chat.agent.mission import Mission
from robot_voice_chat.agent.recovery import SUMMARY, stopped_after_restart
from robot_voice_chat.control.approvals import asked_for
from robot_voice_chat.control.latch import latched_sentence
from robot_voice_chat.control.latch_store import LatchState
from robot_voice_chat.pipeline.chat import ChatPipeline, busy_message
from robot_voice_chat.robot_words import check_robot_words, leaks, witnessing
from robot_voice_chat.services.llm.rules.chat import INTRO, RulesChat
from robot_voice_chat.services.llm.rules.plain import (
    down_sentence,
    part_down,
    reason_of,
    server_part,
    suggestion_of,
)
from robot_voice_chat.services.llm.rules.recollection import (
    NOT_CONNECTED,
    last_seen_sentence,
    last_sightings_sentence,
    recollection,
)
from robot_voice_chat.services.speech.fake import FakeSpeechOutput
from robot_voice_chat.settings import ChatConfig


# --- the checker ----------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("sentence", "kind"),
    [
        ("navigation restarted and no longer knows task nav-7f5d78a8.", "task id"),
        ("I couldn't drive: navigation.navigate_to was not sent.", "tool name"),
        ("I couldn't drive to the kitchen: SAFETY_STOP_LATCHED: stopped.", "error code"),
        ("I couldn't reach the meeting_room: the drive took too long.", "snake_case id"),
        ("look for the scissors in the desk_bob", "snake_case id"),
        ('That didn\'t work: {"error": "timeout"}', "raw server text"),
        ("That didn't work: error: server 'navigation' is not connected", "raw server text"),
        ("I last saw the red mug in the kitchen 12 s ago, for 0 s.", "zero seconds"),
        ("I last saw the red mug 0 s ago.", "zero seconds"),
        ("An emergency stop is latched.", "emergency stop"),
        ("I couldn't reach the mailroom: no path (Nav2 error 208: no valid path).", "error number"),
    ],
)
def test_the_checker_finds_each_kind_of_leak(sentence: str, kind: str) -> None:
    assert kind in [leak.kind for leak in leaks(sentence)], leaks(sentence)


@pytest.mark.parametrize(
    "sentence",
    [
        "I'm at Alice's desk.",
        "I found the package in the mailroom: yellow package (0.91).",
        "I last saw the red mug in the kitchen 10 s ago (15:31:16 UTC).",
        "The mailroom door is closed. I'll use the east entrance via the corridor b.",
        "Stopped. Should I continue or abort?",
        "I saw it just now, 30 s after 3 pm; I went to 2 places.",
    ],
)
def test_plain_sentences_pass(sentence: str) -> None:
    assert leaks(sentence) == []


def test_what_the_fakes_say_is_witnessed() -> None:
    with witnessing() as said:
        speech = FakeSpeechOutput()
        speech.spoken.clear()
    assert said == []
    with witnessing() as said:
        import asyncio

        asyncio.run(FakeSpeechOutput().say("I lost task nav-3."))
    assert [leak.kind for leak in check_robot_words(said)] == ["task id"]


# --- every template, fed what real servers answer -------------------------------------------
SERVER_ERRORS = [
    {"error": "SAFETY_STOP_LATCHED", "detail": "navigation.navigate_to was not sent. stop"},
    {"error": "POLICY_DENIED", "detail": "navigation.navigate_to was not sent: denied (x)"},
    {"error": "NOT_SUPERVISED", "detail": "no fresh lease: navigation.navigate_to refused"},
    {"error": "OUT_OF_BOUNDS", "detail": "location 'desk_carol' is not one_of [dock]"},
    {"error": "NAVIGATION_TIMEOUT", "detail": "call navigate_to again"},
    {"error": "UNKNOWN_LOCATION", "detail": "unknown location 'meeting_room_2'"},
    {"error": "NAVIGATION_BUSY", "detail": "a navigation is running"},
    {"error": "BASE_UNAVAILABLE", "detail": "no NavigateToPose server on /navigate_to_pose"},
    {"error": "service_unavailable", "detail": "the vision node is down"},
    {"error": "timeout", "detail": "no result for skill find_object in 20 s"},
    {"error": "invalid_time", "detail": "start: cannot read the time 'x'"},
    {"error_code": "SERVER_RESTARTED", "message": "navigation restarted, lost task nav-1"},
    {"error_code": "DOOR_CLOSED", "message": "The mailroom door is closed."},
]
BACKEND_ERRORS = [
    "error: server 'navigation' is not connected",
    "error: navigation.navigate_to timed out after 30 s",
    "error: skill_control.instantiate_skill failed: ConnectError: All connection attempts",
    "unknown tool manipulation.pick",
]
OFFICE_PLACES = PlaceIndex.from_result(OFFICE_LIST_LOCATIONS)


@pytest.mark.parametrize(
    "content", [json.dumps(e) for e in SERVER_ERRORS] + BACKEND_ERRORS, ids=repr
)
def test_every_tool_error_is_said_in_plain_words(content: str) -> None:
    said = reason_of(content, OFFICE_PLACES.spoken, OFFICE_PLACES.known())
    assert said
    assert leaks(said) == [], said


@pytest.mark.parametrize(
    ("why", "said"),
    [
        ("denied by alice", "the operator (alice) said no"),
        ("wrong room", "the operator said no: wrong room"),
        ("answered 'no'", "the operator said no"),
        ("no answer within 60 s", "nobody approved it in time (no answer within 60 s)"),
        ("safety stop: operator", "a stop withdrew the request for approval"),
    ],
)
def test_an_approval_not_given_is_said_as_what_happened_not_as_the_policy(
    why: str, said: str
) -> None:
    detail = f"navigation.navigate_to was not sent: denied ({why})"
    content = json.dumps({"error": "POLICY_DENIED", "detail": detail, "approval": "denied"})
    assert reason_of(content) == said
    assert "policy" not in said


@pytest.mark.parametrize("suggestion", [*DOOR_SUGGESTIONS, "retry", "retry_after_s:300"])
def test_a_suggestion_is_said_plainly_or_not_at_all(suggestion: str) -> None:
    said = suggestion_of(suggestion, OFFICE_PLACES.spoken, ["corridor_b", "mailroom"])
    assert said is None or leaks(said) == [], said


def sighting(place: str, ago: str = "12 s ago", **extra: Any) -> dict[str, Any]:
    when = {"time": "2026-11-26T15:31:16.000Z", "ago": ago, "local": "15:31:16 UTC"}
    return {"label": "red mug", "place": place, "last_seen": when, "first_seen": when, **extra}


TEMPLATES: list[tuple[str, Callable[[], str]]] = [
    ("recovery summary", lambda: SUMMARY),
    ("stopped after restart", lambda: stopped_after_restart("navigation")),
    ("stop question", lambda: STOP_QUESTION),
    ("intro", lambda: INTRO),
    ("no episodic", lambda: NOT_CONNECTED),
    (
        "latched",
        lambda: latched_sentence(
            LatchState(latched=True, since=time.time(), by="alice", reason="Stop (asked in chat)")
        ),
    ),
    ("busy", lambda: busy_message(Mission.new("go to desk_alice, then fetch mug from kitchen"))),
    ("approval of a drive", lambda: asked_for("navigation.navigate_to", {"location": "desk_bob"})),
    ("approval of a save", lambda: asked_for("memory.save_process", {"markdown": "x"})),
    ("approval of anything", lambda: asked_for("manipulation.pick_object", {})),
    (
        "last seen, a glimpse",
        lambda: last_seen_sentence(
            {
                "found": True,
                "results": [sighting("desk_alice", seen_for="0 s", seen_for_s=0.2)],
            },
            None,
            OFFICE_PLACES.spoken,
        ),
    ),
    (
        "last seen, by id",
        lambda: last_seen_sentence({"found": True, "results": [sighting("corridor_b")]}, None),
    ),
    (
        "recollection of a server error",
        lambda: recollection(
            None,
            LAST_SEEN,
            json.dumps({"error": "invalid_argument", "detail": "query 'the' has no words"}),
            True,
        ),
    ),
    (
        "last sightings",
        lambda: last_sightings_sentence(
            json.dumps({"items": [sighting("meeting_room", ago="just now")]}),
            OFFICE_PLACES.spoken,
        ),
    ),
    # issue 39: abort, the busy reply, the part that does not answer
    ("busy note", lambda: busy_note(Mission.new("go to desk_alice"), None)),
    ("aborting", lambda: aborting_note(Mission.new("go to meeting_room"))),
    ("aborted", lambda: aborted_summary(Mission.new("fetch the mug from the kitchen"))),
    *[
        (f"down: {server}", lambda server=server: down_sentence(server_part(server), "look"))
        for server in ("perception", "skill_control", "manipulation", "navigation", "episodic")
    ],
    *[
        (
            f"down: {code}",
            lambda code=code: down_sentence(
                part_down(json.dumps({"error": code, "detail": "/vision/create_skill x_y"})) or "",
                "look for the red mug",
            ),
        )
        for code in ("service_unavailable", "service_timeout", "ARM_UNAVAILABLE")
    ],
    (
        "resume a drive",
        lambda: suggestion_of('call navigate_to("desk_bob") to resume the drive') or "",
    ),
]


@pytest.mark.parametrize(("name", "template"), TEMPLATES, ids=[n for n, _ in TEMPLATES])
def test_every_sentence_template_is_plain(name: str, template: Callable[[], str]) -> None:
    said = template()
    assert said
    assert leaks(said) == [], said


def test_a_glimpse_is_not_said_as_seen_for_zero_seconds() -> None:
    data = {"found": True, "results": [sighting("kitchen", seen_for="0 s", seen_for_s=0.1)]}
    assert "for" not in last_seen_sentence(data, None).split("(", 1)[1]


def test_where_is_it_now_names_the_last_place_only_and_when_did_you_see_it_names_both() -> None:
    data = {"found": True, "results": [sighting("reception"), sighting("mailroom", "2 min ago")]}
    now = read_recall("where is the red mug now?")
    then = read_recall("when did you last see the red mug?")
    assert now is not None
    assert now.offer
    assert then is not None
    assert not then.offer
    assert "mailroom" not in last_seen_sentence(data, now)
    assert "Before that I saw it in the mailroom 2 min ago." in last_seen_sentence(data, then)


# --- missions that fail every way the offline planner knows ---------------------------------
def _door_stays_shut(o: Office) -> None:
    o.world.door_closed = True
    o.tools.add(
        "navigation.navigate_to",
        lambda a: (_ for _ in ()).throw(
            ValueError(json.dumps({"error": "DOOR_CLOSED", "detail": "The door is closed."}))
        ),
        location="string",
    )


def _latched(o: Office) -> None:
    detail = "navigation.navigate_to was not sent. The robot is stopped."
    o.tools.add(
        "navigation.navigate_to",
        lambda a: (_ for _ in ()).throw(
            ValueError(json.dumps({"error": "SAFETY_STOP_LATCHED", "detail": detail}))
        ),
        location="string",
    )


def _vision_down(o: Office) -> None:
    down = json.dumps({"error": "service_unavailable", "detail": "vision node down"})
    for tool in ("perception.wait_for_result", "skill_control.list_running_skills"):
        o.tools.add(tool, lambda a, d=down: (_ for _ in ()).throw(ValueError(d)))


def _navigation_down(o: Office) -> None:
    o.tools.states["navigation"] = "disconnected"


FAILURES: list[tuple[str, Callable[[Office], None], str]] = [
    ("a closed door with suggestions", lambda o: None, "fetch the package from the mailroom"),
    ("a door that stays shut", _door_stays_shut, "go to the mailroom"),
    ("a latched stop", _latched, "go to the kitchen"),
    ("the camera down", _vision_down, "find the scissors in the kitchen"),
    ("navigation down", _navigation_down, "go to the kitchen"),
    ("an unknown place", lambda o: None, "go to the garden shed"),
    ("something not understood", lambda o: None, "sing me a song"),
    ("nothing seen", lambda o: None, "find the stapler"),
]


@pytest.mark.parametrize(("name", "setup", "request_text"), FAILURES, ids=[f[0] for f in FAILURES])
async def test_what_the_robot_says_when_a_mission_fails_is_plain(
    tmp_path: Path, name: str, setup: Callable[[Office], None], request_text: str
) -> None:
    o = office(tmp_path)
    setup(o)
    with witnessing() as said:
        mission = await o.run(request_text)
    assert mission.summary in said
    assert check_robot_words(said) == [], said


CHAT_TURNS = [
    "look for the scissors at Bob's desk",
    "go to Alice's desk",
    "which places do you know?",
    "where are you?",
    "hello",
    "go to the garden shed",
]


@pytest.mark.parametrize("turn", CHAT_TURNS)
async def test_what_the_offline_chat_answers_is_plain_and_names_places(
    tmp_path: Path, turn: str
) -> None:
    o = office(tmp_path)
    o.tools.add("navigation.list_locations", lambda a: json.loads(OFFICE_LIST_LOCATIONS))
    o.tools.add(
        "navigation.get_pose",
        lambda a: (_ for _ in ()).throw(
            ValueError(json.dumps({"error": "BASE_UNAVAILABLE", "detail": "no /amcl_pose"}))
        ),
    )
    pipeline = ChatPipeline(
        llm=RulesChat(),
        tools=o.tools,
        executor=o.executor,
        emitter=o.emitter,
        speech=o.speech,
        config=ChatConfig(),
    )
    with witnessing() as said:
        result = await pipeline.handle_turn(turn)
        await o.executor.wait_idle(10)
    assert result.reply in said
    assert check_robot_words(said) == [], said
    if "desk" in turn:
        assert any("desk" in line and "_" not in line for line in said)
