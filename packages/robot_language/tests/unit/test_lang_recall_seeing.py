"""Kinds of questions about the past fresh_3 found missing (issue 20): other verbs of seeing
("catch sight of", "come across", "lay eyes on"), the robot named in the third person as the one
who saw, and "was there anything in P at T" / "anything at P earlier?" as what was seen there.
None of them is ever an action; a request that uses the same words stays a request."""

from __future__ import annotations

import pytest

from robot_language.places import PlaceIndex
from robot_language.recall import LAST_SEEN, read_recall
from robot_language.scoring import OFFICE_LIST_LOCATIONS
from robot_language.understand import Understanding
from robot_stack_testing.brain.episodic_chat import SIGHTINGS_ONLY

OFFICE = PlaceIndex.from_result(OFFICE_LIST_LOCATIONS)


@pytest.mark.parametrize(
    "text",
    [
        "when did you last catch sight of the notebook?",
        "where did you catch a glimpse of the notebook",
        "when did you last lay eyes on the notebook",
        "have you ever laid eyes on the notebook?",
        "where did you glimpse the notebook",
        "have you come across the notebook today?",
        "did you run into the notebook earlier?",
        "when did you last set eyes on the notebook",
        "the last time you caught sight of the notebook?",
    ],
)
def test_other_verbs_of_seeing_are_its_last_sighting(text: str) -> None:
    recall = read_recall(text)
    assert recall is not None, text
    assert (recall.tool, recall.arguments) == (LAST_SEEN, {"query": "notebook"})


@pytest.mark.parametrize(
    ("text", "place"),
    [
        ("what did the robot see at the reception desk?", "reception desk"),
        ("what did it see in the mailroom", "mailroom"),
        ("what did the bot spot in the kitchen", "kitchen"),
        ("what has the robot noticed in the kitchen", "kitchen"),
    ],
)
def test_the_robot_in_the_third_person_is_the_one_who_saw(text: str, place: str) -> None:
    recall = read_recall(text)
    assert recall is not None, text
    assert recall.arguments == {**SIGHTINGS_ONLY, "place": place, "start": "-24h"}


@pytest.mark.parametrize(
    ("text", "thing"),
    [("did the robot see the laptop?", "laptop"), ("when did it last spot the mug", "mug"),
     ("has your robot come across my keys", "keys")],
)  # fmt: skip
def test_did_the_robot_see_a_thing_is_its_last_sighting(text: str, thing: str) -> None:
    recall = read_recall(text)
    assert recall is not None, text
    assert (recall.tool, recall.arguments) == (LAST_SEEN, {"query": thing})


@pytest.mark.parametrize(
    ("text", "place", "start", "end"),
    [
        ("was there anything in the kitchen at 3:29 pm?", "kitchen", "3:29pm -5m", "3:29pm +5m"),
        ("was there anyone at the front desk at about 2:25", "front desk", "2:25pm -5m",
         "2:25pm +5m"),
        ("anything at the reception earlier?", "reception", "-24h", None),
        ("anyone in the mailroom in the last hour?", "mailroom", "-3600s", None),
        ("was there anything in the meeting room", "meeting room", "-24h", None),
    ],
)  # fmt: skip
def test_anything_at_a_place_and_time_is_what_was_seen_there(
    text: str, place: str, start: str, end: str | None
) -> None:
    recall = read_recall(text)
    assert recall is not None, text
    window = {"start": start} if end is None else {"start": start, "end": end}
    assert recall.arguments == {**SIGHTINGS_ONLY, "place": place, **window}


@pytest.mark.parametrize(
    "text",
    [
        "was there anything in the kitchen at 3:29 pm?",
        "anything at the reception earlier?",
        "what did the robot see at the reception desk?",
        "when did you last catch sight of the notebook?",
    ],
)
def test_they_are_answered_never_acted_on(understanding: Understanding, text: str) -> None:
    reading = understanding.understand(text, OFFICE)
    assert (reading.kind, reading.actions, reading.recall is not None) == ("answer", [], True)


@pytest.mark.parametrize(
    "text",
    [
        "run into the kitchen and get the mug",
        "anything in the kitchen?",
        "when was it seen",
        "what did alice see in the kitchen",
    ],
)
def test_the_same_words_without_a_past_sighting_by_the_robot_are_no_recall(text: str) -> None:
    assert read_recall(text) is None


@pytest.mark.parametrize(
    ("text", "place"),
    [
        ("what's in the kitchen", "kitchen"),
        ("what is at reception?", "reception"),
        ("what's there in the mailroom", "mailroom"),
        ("what is inside the meeting room", "meeting room"),
        ("what's on Bob's desk", "bob's desk"),
        ("what is lying on the kitchen table", "kitchen table"),
    ],
)
def test_what_is_in_a_place_is_what_it_saw_there_never_a_drive(
    understanding: Understanding, text: str, place: str
) -> None:
    recall = read_recall(text)
    assert recall is not None, text
    assert recall.kind == "seen"
    assert recall.place == place
    reading = understanding.understand(text, OFFICE)
    assert reading.kind == "answer"
    assert reading.actions == []


@pytest.mark.parametrize(
    "text",
    [
        "what's in view?",
        "what is in front of you",
        "what's in your gripper",
        "what's on your mind",
        "what did you see on monday",
    ],
)
def test_what_is_in_view_or_in_its_hand_is_not_a_place_it_saw(text: str) -> None:
    recall = read_recall(text)
    assert recall is None or recall.place is None, text
