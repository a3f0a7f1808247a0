"""Questions about the past (issue 20): read into one episodic call, answered in short true
sentences by the rules chat and the rules planner, never a motion; a cold "what do you see"
says what the robot saw last (seed 000 §8, historical mode)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from robot_language.recall import (
    LAST_SEEN,
    POSE_AT,
    WHAT_HAPPENED,
    read_recall,
)
from robot_language.scoring import OFFICE_LIST_LOCATIONS
from robot_language.understand import Understanding
from robot_stack_testing.brain.office import office
from robot_voice_chat.pipeline.fast_tools import FAST_LOCAL_TOOLS
from robot_voice_chat.services.llm.base import LLMResponse, Message, ToolDefinition, ToolResult
from robot_voice_chat.services.llm.rules.chat import RulesChat
from robot_voice_chat.services.llm.rules.recollection import NOT_CONNECTED, recollection

EPISODIC = [ToolDefinition(name=n) for n in (WHAT_HAPPENED, LAST_SEEN, POSE_AT)]
TOOLS = [*FAST_LOCAL_TOOLS, *EPISODIC]
MUG = {
    "query": "mug", "found": True, "place": None,
    "results": [{
        "label": "red mug", "place": "meeting_room", "seen_for": "30 s",
        "last_seen": {"time": "2026-09-21T15:31:16.000Z", "ago": "1 h 41 min ago"},
        "absent_since": None,
    }],
}  # fmt: skip
SIGHTINGS = {
    "start": {"ago": "1 d ago"}, "truncated": False,
    "items": [
        {"kind": "sighting", "label": "charger", "place": "dock", "ago": "3 h ago",
         "time": "2026-09-21T14:13:20.500Z"},
        {"kind": "sighting", "label": "parcel", "place": "mailroom", "ago": "1 h 40 min ago",
         "time": "2026-09-21T15:33:20.500Z"},
    ],
}  # fmt: skip


@pytest.mark.parametrize(
    ("text", "tool", "arguments"),
    [
        ("what did you see 30 seconds ago?", WHAT_HAPPENED,
         {"kinds": ["sightings"], "start": "-45s", "end": "-15s", "max_items": 100}),
        ("What did you see a minute ago", WHAT_HAPPENED,
         {"kinds": ["sightings"], "start": "-90s", "end": "-30s", "max_items": 100}),
        ("when did you last see the mug?", LAST_SEEN, {"query": "mug"}),
        ("where did you see the scissors", LAST_SEEN, {"query": "scissors"}),
        ("did you see the red mug in the kitchen today?", LAST_SEEN,
         {"query": "red mug", "place": "kitchen"}),
        ("what happened in the last 10 minutes", WHAT_HAPPENED,
         {"start": "-600s", "max_items": 100}),
        ("what happened today", WHAT_HAPPENED, {"start": "00:00", "max_items": 100}),
        ("what happened while I was away", WHAT_HAPPENED, {"start": "-1h", "max_items": 100}),
        ("where were you at 3 pm", POSE_AT, {"time": "3pm"}),
        ("where were you at 15:30?", POSE_AT, {"time": "15:30"}),
        ("Where were you 10 minutes ago?", POSE_AT, {"time": "-600s"}),
        # a clock time: the server's window around it, the clock passed as said
        ("what did you see at 3 pm", WHAT_HAPPENED,
         {"kinds": ["sightings"], "start": "3pm -5m", "end": "3pm +5m", "max_items": 100}),
        ("What did you see around 15:30?", WHAT_HAPPENED,
         {"kinds": ["sightings"], "start": "15:30 -5m", "end": "15:30 +5m", "max_items": 100}),
        ("what did you see at half past two", WHAT_HAPPENED,
         {"kinds": ["sightings"], "start": "2:30pm -5m", "end": "2:30pm +5m", "max_items": 100}),
        ("what did you see at noon", WHAT_HAPPENED,
         {"kinds": ["sightings"], "start": "12:00pm -5m", "end": "12:00pm +5m",
          "max_items": 100}),
        ("what did you spot in the mailroom around 3:32 pm", WHAT_HAPPENED,
         {"kinds": ["sightings"], "start": "3:32pm -5m", "end": "3:32pm +5m", "max_items": 100,
          "place": "mailroom"}),
        ("what happened at 2:24 pm", WHAT_HAPPENED,
         {"start": "2:24pm -5m", "end": "2:24pm +5m", "max_items": 100}),
    ],
)  # fmt: skip
def test_a_question_about_the_past_is_one_episodic_call_with_the_times_as_said(
    text: str, tool: str, arguments: dict[str, Any]
) -> None:
    recall = read_recall(text)
    assert recall is not None
    assert (recall.tool, recall.arguments) == (tool, arguments)


@pytest.mark.parametrize(
    "text",
    [
        "go to the kitchen",
        "find the red mug",
        "what do you see",
        "where are you",
        "did you",
        "where were you",
        "have you seen anything",
    ],
)  # fmt: skip  ("where is the mug": its last sighting and an offer, test_rvc_recall_where_now)
def test_requests_and_present_questions_are_not_questions_about_the_past(text: str) -> None:
    recall = read_recall(text)
    assert recall is None or recall.tool == WHAT_HAPPENED  # "seen anything": a digest, no motion
    if text != "have you seen anything":
        assert recall is None


async def _ask(chat: RulesChat, messages: list[Message], content: str, tools=TOOLS) -> Any:  # type: ignore[no-untyped-def]
    messages.append(Message(role="user", content=content))
    return await chat.chat(messages, tools)


async def _answer(chat: RulesChat, messages: list[Message], response: LLMResponse, result: Any,
                  is_error: bool = False) -> str:  # fmt: skip
    [call] = response.tool_calls
    messages += [
        response.as_message(),
        Message(role="user", tool_results=[ToolResult(
            tool_call_id=call.id, content=json.dumps(result) if not isinstance(result, str)
            else result, is_error=is_error)]),
    ]  # fmt: skip
    reply = await chat.chat(messages, TOOLS)
    assert not reply.tool_calls
    messages.append(Message(role="assistant", content=reply.text))
    return reply.text


async def test_the_rules_chat_answers_when_it_last_saw_something(
    understanding: Understanding,
) -> None:
    chat, messages = RulesChat(understanding), []
    response = await _ask(chat, messages, "When did you last see the mug, and where?")
    assert [(c.name, c.arguments) for c in response.tool_calls] == [(LAST_SEEN, {"query": "mug"})]
    text = await _answer(chat, messages, response, MUG)
    assert text.startswith("I last saw the red mug in the meeting room 1 h 41 min ago")
    assert "15:31:16 UTC" in text


async def test_nothing_seen_is_said_and_never_guessed(understanding: Understanding) -> None:
    chat, messages = RulesChat(understanding), []
    response = await _ask(chat, messages, "have you seen my umbrella?")
    none = {"query": "umbrella", "found": False, "place": None, "results": []}
    assert await _answer(chat, messages, response, none) == (
        "I have no record of seeing the umbrella."
    )
    response = await _ask(chat, messages, "what did you see a minute ago?")
    empty = {"start": {"ago": "90 s ago"}, "items": [], "truncated": False}
    assert await _answer(chat, messages, response, empty) == (
        "I have no record of seeing anything around a minute ago."
    )


async def test_without_episodic_the_chat_says_so_in_one_sentence(
    understanding: Understanding,
) -> None:
    chat = RulesChat(understanding)
    reply = await _ask(chat, [], "what happened while I was away?", FAST_LOCAL_TOOLS)
    assert not reply.tool_calls
    assert reply.text == NOT_CONNECTED


async def test_a_tool_error_is_read_out_as_its_detail(understanding: Understanding) -> None:
    chat, messages = RulesChat(understanding), []
    response = await _ask(chat, messages, "where were you at 3 pm")
    error = {"error": "store_unavailable", "detail": "the index database is locked"}
    text = await _answer(chat, messages, response, error, is_error=True)
    assert text == "I couldn't look that up in my memory: the index database is locked"


async def test_while_away_starts_at_the_previous_turn_else_the_last_hour(
    understanding: Understanding,
) -> None:
    now = [1_790_000_000.0]
    chat, messages = RulesChat(understanding, clock=lambda: now[0]), []
    first = await _ask(chat, messages, "what did I miss?")
    assert first.tool_calls[0].arguments["start"] == "-1h"
    text = await _answer(chat, messages, first, {"start": {"ago": "1 h ago"}, "items": []})
    assert text == (
        "I have no record of anything happening in the last hour (I don't know when you left)."
    )
    now[0] += 600
    second = await _ask(chat, messages, "what happened while I was away")
    assert second.tool_calls[0].arguments["start"] == "2026-09-21T14:13:20.000+00:00"
    digest = {"start": {"ago": "10 min ago"}, "truncated": False, "items": [
        {"kind": "visit", "place": "kitchen"},
        {"kind": "mission_started", "text": "Evening patrol", "ago": "9 min ago"},
        {"kind": "sighting", "label": "parcel", "place": "mailroom", "ago": "5 min ago"},
        {"kind": "user", "text": "hello"},
    ]}  # fmt: skip
    text = await _answer(chat, messages, second, digest)
    assert text == (
        "Since you last spoke to me (10 min ago): I was in the kitchen; missions: started "
        "“Evening patrol” 9 min ago; I saw the parcel in the mailroom; you said “hello”."
    )


async def test_while_away_never_reports_the_question_itself_as_something_that_happened(
    understanding: Understanding,
) -> None:
    chat, messages = RulesChat(understanding), []
    asked = "what happened while I was away?"
    response = await _ask(chat, messages, asked)
    digest = {"start": {"ago": "1 h ago"}, "truncated": False, "items": [
        {"kind": "user", "text": "go to the kitchen"},
        {"kind": "robot", "text": "I'm in the kitchen."},
        {"kind": "user", "text": "hello"},
        {"kind": "user", "text": asked},  # the brain recorded this turn before asking
    ]}  # fmt: skip
    text = await _answer(chat, messages, response, digest)
    assert asked not in text
    assert text.endswith("I said “I'm in the kitchen.”; you said “hello” (and 1 more line of "
                         "conversation).")  # fmt: skip


def test_a_digest_ending_on_a_quoted_sentence_ends_once() -> None:
    digest = {"start": {"ago": "5 min ago"}, "truncated": False, "items": [
        {"kind": "user", "text": "have you seen my keys?"},
        {"kind": "robot", "text": "I have no record of seeing the keys."},
    ]}  # fmt: skip
    text = recollection(None, WHAT_HAPPENED, json.dumps(digest), False)
    assert text.endswith("I said “I have no record of seeing the keys.”")


def test_a_clock_time_is_answered_with_the_servers_window_or_says_nothing_was_seen() -> None:
    recall = read_recall("what did you see at 3 pm")
    window = {
        "start": {"time": "2026-09-21T13:55:00.000Z", "local": "2026-09-21 14:55:00 CET"},
        "end": {"time": "2026-09-21T14:05:00.000Z", "local": "2026-09-21 15:05:00 CET"},
    }
    mug = {"kind": "sighting", "label": "red mug", "place": "kitchen", "ago": "2 h ago"}
    seen = {**window, "items": [mug]}
    assert recollection(recall, WHAT_HAPPENED, json.dumps(seen), False) == (
        "Between 14:55 and 15:05 CET I saw the red mug in the kitchen (first seen 2 h ago)."
    )
    nothing = {**window, "items": []}
    assert recollection(recall, WHAT_HAPPENED, json.dumps(nothing), False) == (
        "I have no record of seeing anything around 3 pm (between 14:55 and 15:05 CET)."
    )
    # without the site's clock, the UTC times; a window across a clock change says both zones
    utc = {"start": {"time": "2026-09-21T13:55:00.000Z"}, "end": {"time": "2026-09-21T14:05:00Z"}}
    assert recollection(recall, WHAT_HAPPENED, json.dumps({**utc, "items": []}), False).endswith(
        "(between 13:55 and 14:05 UTC)."
    )
    change = {
        "start": {"local": "2026-10-25 02:55:00 CEST"},
        "end": {"local": "2026-10-25 02:05:00 CET"},
        "items": [mug],
    }
    assert recollection(recall, WHAT_HAPPENED, json.dumps(change), False).startswith(
        "Between 02:55 CEST and 02:05 CET I saw"
    )
    digest = read_recall("what happened at 2:24 pm")
    assert recollection(digest, WHAT_HAPPENED, json.dumps(nothing), False) == (
        "I have no record of anything happening around 2:24 pm (between 14:55 and 15:05 CET)."
    )


def test_a_pose_and_a_place_filter_are_said_as_asked() -> None:
    recall = read_recall("where were you at 3 pm?")
    pose = {"found": True, "time": "2026-09-21T15:00:00.000Z", "place": None,
            "pose": {"x": 1.25, "y": -2.0}, "mission": None}  # fmt: skip
    assert recollection(recall, POSE_AT, json.dumps(pose), False) == (
        "At 3pm (15:00:00 UTC) I was between places, at x=1.2 m, y=-2.0 m."
    )
    missing = {"found": False, "time": "2026-09-21T15:00:00.000Z"}
    assert recollection(recall, POSE_AT, json.dumps(missing), False) == (
        "I have no record of where I was at 3pm (15:00:00 UTC)."
    )
    # a site in Berlin: the server read "3 pm" there and gives its wall clock beside UTC
    local = {**pose, "time": "2026-09-21T13:00:00.000Z", "local": "2026-09-21 15:00:00 CEST"}
    assert recollection(recall, POSE_AT, json.dumps(local), False) == (
        "At 3pm (15:00:00 CEST) I was between places, at x=1.2 m, y=-2.0 m."
    )
    recall = read_recall("did you see the scissors in the kitchen")
    none = {"found": False, "results": [], "place": "kitchen"}
    assert recollection(recall, LAST_SEEN, json.dumps(none), False) == (
        "I have no record of seeing the scissors in the kitchen."
    )
    assert recollection(None, LAST_SEEN, "not json", False).startswith("I couldn't look")


async def test_the_rules_planner_answers_a_question_about_the_past_without_moving(
    tmp_path: Path,
) -> None:
    o = office(tmp_path)
    o.tools.add(LAST_SEEN, lambda a: MUG, query="string")
    mission = await o.run("when did you last see the mug?")
    assert mission.state == "succeeded", mission.summary
    assert mission.summary.startswith("I last saw the red mug in the meeting room 1 h 41 min ago")
    assert o.tools.called(LAST_SEEN) == [{"query": "mug"}]
    assert not o.tools.called("navigation.navigate_to")
    mission = await o.run("where were you at 3 pm")
    assert mission.state == "failed"
    assert mission.summary == NOT_CONNECTED


async def test_the_rules_planner_says_places_by_their_human_names(tmp_path: Path) -> None:
    o = office(tmp_path)  # the live place list: desk_alice is "Alice's desk ..."
    o.tools.add("navigation.list_locations", lambda a: json.loads(OFFICE_LIST_LOCATIONS))
    laptop = {
        "query": "laptop", "found": True, "place": "desk_alice",
        "results": [{"label": "laptop", "place": "desk_alice", "seen_for": "20 s",
                     "last_seen": {"time": "2026-09-21T14:27:20.000Z", "ago": "5 min ago"}}],
    }  # fmt: skip
    o.tools.add(LAST_SEEN, lambda a: laptop, query="string", place="string")
    mission = await o.run("did you see the laptop at Alice's desk?")
    assert mission.state == "succeeded", mission.summary
    assert mission.summary.startswith("I last saw the laptop at Alice's desk 5 min ago")
    assert o.tools.called(LAST_SEEN) == [{"query": "laptop", "place": "desk_alice"}]
    o.tools.add(WHAT_HAPPENED, lambda a: SIGHTINGS, start="string", kinds="array")
    mission = await o.run("what did you see today?")
    assert "the charger at the charging dock" in mission.summary
    assert "desk alice" not in (await o.run("when did you last see the laptop")).summary


async def test_a_cold_what_do_you_see_says_what_was_seen_last_and_when(tmp_path: Path) -> None:
    o = office(tmp_path)
    o.tools.add(WHAT_HAPPENED, lambda a: SIGHTINGS, start="string", kinds="array")
    nothing = {"skill": "describe_scene", "detections": [], "outputs": {}}
    o.tools.add("perception.wait_for_result", lambda a: nothing)
    mission = await o.run("what do you see?")
    assert mission.state == "succeeded", mission.summary
    assert mission.summary == (
        "I see nothing new right now. The last I saw: the parcel in the mailroom 1 h 40 min ago "
        "(15:33:20 UTC) and the charger at the dock 3 h ago (14:13:20 UTC)."
    )
    assert o.tools.called(WHAT_HAPPENED) == [
        {"start": "-1d", "kinds": ["sightings"], "max_items": 3}
    ]


async def test_without_perception_what_do_you_see_answers_from_memory(tmp_path: Path) -> None:
    o = office(tmp_path)
    o.tools.add(WHAT_HAPPENED, lambda a: {"items": []}, start="string")
    o.tools._definitions.pop("perception.what_do_you_see")
    mission = await o.run("what do you see?")
    assert mission.summary == (
        "The part of me that collects what my camera sees isn't answering, so I can't look "
        "right now. "
        "I have no record of seeing anything in the last day."
    )
