"""Kinds of questions about the past fresh_2 found missing (issue 20): a hedge before a time
("at about 3:30") is no place, and a follow-up that names one of the map's places ("what about
the reception?") asks about that place, never about a thing called "reception"."""

from __future__ import annotations

import pytest

from robot_language.places import PlaceIndex
from robot_language.recall import (
    LAST_SEEN,
    POSE_AT,
    WHAT_HAPPENED,
    Recall,
    follow_up_recall,
    read_recall,
)
from robot_language.scoring import OFFICE_LIST_LOCATIONS
from robot_language.understand import Understanding
from robot_stack_testing.brain.episodic_chat import recall_turn
from robot_voice_chat.services.llm.base import Message
from robot_voice_chat.services.llm.rules.chat import RulesChat

OFFICE = PlaceIndex.from_result(OFFICE_LIST_LOCATIONS)


def _recalled(text: str) -> Recall:
    recall = read_recall(text)
    assert recall is not None, text
    return recall


@pytest.mark.parametrize("hedge", ["about", "around", "roughly", "approximately", "just"])
@pytest.mark.parametrize(
    ("question", "clock"),
    [
        ("what happened at {} 3:30 in the afternoon", "3:30pm"),
        ("what did you see at {} 2:26 pm", "2:26pm"),
        ("what did you see at {} half past two", "2:30pm"),
    ],
)
def test_a_hedge_before_a_time_is_never_a_place(hedge: str, question: str, clock: str) -> None:
    recall = _recalled(question.format(hedge))
    assert recall.tool == WHAT_HAPPENED
    assert "place" not in recall.arguments
    assert recall.place is None
    assert (recall.arguments["start"], recall.arguments["end"]) == (f"{clock} -5m", f"{clock} +5m")


def test_a_hedged_clock_time_still_keeps_a_real_place() -> None:
    recall = _recalled("what did you see in the kitchen at about 3:29 pm")
    assert (recall.place, recall.arguments["start"]) == ("kitchen", "3:29pm -5m")


@pytest.mark.parametrize("hedge", ["about", "roughly", "approximately"])
def test_where_were_you_at_a_hedged_time_is_the_pose_then(hedge: str) -> None:
    recall = _recalled(f"where were you at {hedge} 2:26 pm")
    assert (recall.tool, recall.arguments) == (POSE_AT, {"time": "2:26pm"})


@pytest.mark.parametrize(
    ("first", "then", "place"),
    [
        ("what did you see in the kitchen today", "what about the reception?", "reception"),
        ("what did you notice in the mailroom?", "and the kitchen?", "kitchen"),
        ("what happened in the last 2 hours", "what about the post room", "post room"),
    ],
)
def test_a_follow_up_naming_a_known_place_asks_about_that_place(
    first: str, then: str, place: str
) -> None:
    previous = _recalled(first)
    recall = follow_up_recall(then, previous, OFFICE.only_place)
    assert recall is not None
    assert (recall.tool, recall.kind, recall.place) == (WHAT_HAPPENED, previous.kind, place)
    assert recall.arguments["start"] == previous.arguments["start"]


def test_a_follow_up_naming_a_place_after_a_sighting_asks_for_the_thing_there() -> None:
    recall = follow_up_recall(
        "what about the meeting room?",
        _recalled("did you see the red mug in the kitchen?"),
        OFFICE.only_place,
    )
    assert recall is not None
    assert (recall.tool, recall.arguments) == (
        LAST_SEEN,
        {"query": "red mug", "place": "meeting room"},
    )


def test_a_follow_up_naming_a_thing_is_still_another_thing() -> None:
    recall = follow_up_recall(
        "and the laptop?", _recalled("what did you see in the kitchen today"), OFFICE.only_place
    )
    assert recall is not None
    assert (recall.tool, recall.arguments) == (LAST_SEEN, {"query": "laptop"})


def test_a_place_after_where_were_you_is_not_guessed() -> None:
    assert (
        follow_up_recall(
            "what about the kitchen?", _recalled("where were you at 3 pm"), OFFICE.only_place
        )
        is None
    )


async def test_the_chat_reads_what_about_the_reception_as_the_place() -> None:
    chat, messages = RulesChat(Understanding()), []
    await recall_turn(chat, messages, "what did you see in the kitchen today")
    messages.append(Message(role="assistant", content="Today I saw the red mug in the kitchen."))
    response = await recall_turn(chat, messages, "what about the reception?")
    [call] = response.tool_calls
    assert (call.name, call.arguments) == (
        WHAT_HAPPENED,
        {"max_items": 100, "kinds": ["sightings"], "place": "reception", "start": "00:00"},
    )
