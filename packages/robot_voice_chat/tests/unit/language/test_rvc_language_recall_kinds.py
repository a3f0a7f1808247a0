"""Kinds of questions about the past the fresh set found missing (issue 20): chatty openers
and "where did X end up", places named by the map's aliases ("the front desk"), clock times in
words ("ten past four") and "and before that?" read against the previous question. Each is
read into one episodic call the server resolves; what cannot be read is said so, never acted on."""

from __future__ import annotations

import json
from typing import Any

import pytest

from robot_language.recall import (
    LAST_SEEN,
    POSE_AT,
    WHAT_HAPPENED,
    follow_up_recall,
    looks_like_recall,
    read_recall,
)
from robot_language.scoring import OFFICE_LOCATIONS
from robot_language.understand import NOT_READ_RECALL, Understanding
from robot_stack_testing.brain.episodic_chat import SIGHTINGS_ONLY, recall_turn
from robot_voice_chat.services.llm.base import Message
from robot_voice_chat.services.llm.rules.chat import RulesChat
from robot_voice_chat.services.llm.rules.recollection import recollection


@pytest.mark.parametrize(
    ("text", "thing"),
    [
        ("yo, where did the scissors end up?", "scissors"),
        ("hey robot, where did my mug go?", "mug"),
        ("ok so where has the parcel got to", "parcel"),
        ("where did the laptop wind up", "laptop"),
        ("hey, when did you last see the charger?", "charger"),
        ("um, have you seen my keys?", "keys"),
    ],
)
def test_where_a_thing_ended_up_is_its_last_sighting_whatever_the_opener(
    text: str, thing: str
) -> None:
    recall = read_recall(text)
    assert recall is not None, text
    assert (recall.tool, recall.arguments) == (LAST_SEEN, {"query": thing})


@pytest.mark.parametrize(
    "text", ["where did you go in the last 3 hours", "where have you been in the last hour"]
)
def test_where_the_robot_went_stays_its_visits(text: str) -> None:
    recall = read_recall(text)
    assert recall is not None
    assert recall.kind == "visits"


@pytest.mark.parametrize(
    ("text", "place"),
    [
        ("what things did you notice at the front desk?", "front desk"),
        ("what stuff did you spot in the meeting room", "meeting room"),
        ("what objects did you see at reception", "reception"),
    ],
)
def test_what_was_noticed_at_a_place_is_the_sightings_there(text: str, place: str) -> None:
    recall = read_recall(text)
    assert recall is not None, text
    assert (recall.tool, recall.arguments) == (
        WHAT_HAPPENED,
        {**SIGHTINGS_ONLY, "place": place, "start": "-24h"},
    )


def test_in_front_of_you_is_still_no_place() -> None:
    recall = read_recall("what was in front of you a minute ago")
    assert recall is not None
    assert "place" not in recall.arguments


async def test_the_front_desk_is_reception_by_the_maps_alias(
    understanding: Understanding,
) -> None:
    response = await recall_turn(
        RulesChat(understanding), [], "what things did you notice at the front desk?"
    )
    [call] = response.tool_calls
    assert (call.name, call.arguments["place"]) == (WHAT_HAPPENED, "reception")


async def test_without_the_alias_the_front_desk_is_said_unknown_never_guessed(
    understanding: Understanding,
) -> None:
    """A map that does not call reception the front desk: no synonym in the grammar guesses."""
    locations = [
        {**place, "aliases": []} if place["name"] == "reception" else place
        for place in OFFICE_LOCATIONS
    ]
    listed = json.dumps({"map": "office", "locations": locations})
    response = await recall_turn(
        RulesChat(understanding), [], "what things did you notice at the front desk?", listed
    )
    assert not response.tool_calls
    assert response.text.startswith("I don't know a place called 'front desk'.")


@pytest.mark.parametrize(
    ("text", "time"),
    [
        ("where were you at ten past four", "4:10pm"),
        ("where were you at quarter to five", "4:45pm"),
        ("where were you at twenty to three", "2:40pm"),
        ("where were you at five past two", "2:05pm"),
        ("where were you at twenty-five to six", "5:35pm"),
        ("where were you at 25 past 3", "3:25pm"),
        ("where were you at 25 minutes to 3", "2:35pm"),
        ("where were you at ten past nine", "9:10am"),
        ("where were you at ten past four pm", "4:10pm"),
        ("where were you at ten after eight in the evening", "8:10pm"),
        ("where were you at quarter of five", "4:45pm"),
        ("where were you at four o'clock", "4:00pm"),
        ("where were you at 9:15 in the evening", "9:15pm"),
        ("where were you at noon", "12:00pm"),
        ("where were you at midnight", "00:00"),
    ],
)
def test_clock_times_in_words_go_to_the_server_as_clock_times(text: str, time: str) -> None:
    """The am/pm rule of "at 3": 1-7 and 12 in the afternoon, 8-11 in the morning."""
    recall = read_recall(text)
    assert recall is not None, text
    assert (recall.tool, recall.arguments) == (POSE_AT, {"time": time})


@pytest.mark.parametrize(
    "text",
    ["what did you see five to ten minutes ago", "what did you see two to three minutes ago"],
)
def test_a_range_of_durations_is_no_clock_time(text: str) -> None:
    recall = read_recall(text)
    assert recall is not None
    assert (recall.tool, recall.arguments["start"][0]) == (WHAT_HAPPENED, "-")  # relative
    assert ":" not in recall.arguments.get("end", "")


def _recalled(text: str) -> Any:
    recall = read_recall(text)
    assert recall is not None, text
    return recall


@pytest.mark.parametrize(
    ("first", "then", "arguments", "said"),
    [
        ("where were you an hour ago", "and before that?", {"time": "-7200s"}, "2 hours ago"),
        ("where were you 10 minutes ago", "what about 5 minutes earlier?", {"time": "-900s"},
         "15 minutes ago"),
        ("where were you at 4:31 pm", "and an hour before that?", {"time": "4:31pm -3600s"},
         "an hour before 4:31 pm"),
        ("what happened in the last 30 minutes", "and before that?",
         {"max_items": 100, "start": "-3600s", "end": "-1800s"}, "30 minutes earlier"),
        ("what did you see 2 minutes ago", "and before that",
         {**SIGHTINGS_ONLY, "start": "-300s", "end": "-180s"}, "2 minutes earlier"),
        ("what did you see at 3 pm", "and an hour before that?",
         {**SIGHTINGS_ONLY, "start": "3pm -3900s", "end": "3pm -3300s"}, "an hour earlier"),
    ],
)  # fmt: skip
def test_before_that_steps_back_by_the_amount_or_the_questions_own_length(
    first: str, then: str, arguments: dict[str, Any], said: str
) -> None:
    recall = follow_up_recall(then, _recalled(first))
    assert recall is not None
    assert (recall.arguments, recall.said) == (arguments, said)


def test_before_that_again_steps_back_again() -> None:
    once = follow_up_recall("and an hour before that?", _recalled("where were you at 4:31 pm"))
    assert once is not None
    twice = follow_up_recall("and an hour before that?", once)
    assert twice is not None
    assert (twice.arguments, twice.said) == ({"time": "4:31pm -7200s"}, "2 hours before 4:31 pm")


@pytest.mark.parametrize(
    "first",
    ["where were you at 4:31 pm", "what happened today", "when did you last see the mug",
     "what happened while I was away"],
)  # fmt: skip
def test_before_that_without_a_length_to_step_back_is_not_guessed(first: str) -> None:
    assert follow_up_recall("and before that?", _recalled(first)) is None


async def test_an_unreadable_before_that_is_said_not_understood_never_acted_on(
    understanding: Understanding,
) -> None:
    assert looks_like_recall("and before that?")
    reading = understanding.understand("and before that?")
    assert (reading.kind, reading.text) == ("refuse", NOT_READ_RECALL)
    chat, messages = RulesChat(understanding), []
    await recall_turn(chat, messages, "where were you at 4:31 pm")
    messages.append(Message(role="assistant", content="At 4:31pm I was at the dock."))
    response = await recall_turn(chat, messages, "and before that?")
    assert not response.tool_calls
    assert "did not understand" in response.text


async def test_the_chat_steps_back_from_the_previous_question_and_says_when(
    understanding: Understanding,
) -> None:
    chat, messages = RulesChat(understanding), []
    await recall_turn(chat, messages, "where were you an hour ago")
    messages.append(Message(role="assistant", content="An hour ago I was at the dock."))
    response = await recall_turn(chat, messages, "and before that?")
    [call] = response.tool_calls
    assert (call.name, call.arguments) == (POSE_AT, {"time": "-7200s"})
    pose = {"found": True, "time": "2026-09-21T15:13:20.000Z", "place": "dock"}
    recall = follow_up_recall("and before that?", _recalled("where were you an hour ago"))
    assert recollection(recall, POSE_AT, json.dumps(pose), False) == (
        "2 hours ago (15:13:20 UTC) I was at the dock."
    )
