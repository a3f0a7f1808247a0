"""Two things to carry in one request, and a question never said back with a hole in it
("get the mug from , then …"): each thing is fetched in turn and said back first; a place
said once is every thing's; one answer to "where from?" fills every thing that lacked it."""

from __future__ import annotations

from pathlib import Path

import pytest

from robot_language.places import PlaceIndex
from robot_language.reading import Action
from robot_language.scoring import OFFICE_LIST_LOCATIONS, load_set
from robot_language.understand import Understanding

DATA_SETS = sorted((Path(__file__).parent / "data").glob("set_*.yaml"))


@pytest.fixture
def places(understanding: Understanding) -> PlaceIndex:
    return understanding.places(OFFICE_LIST_LOCATIONS)


def test_two_things_from_one_place_are_each_fetched_from_it_and_said_back_first(
    understanding: Understanding, places: PlaceIndex
) -> None:
    reading = understanding.understand("bring the mug and the bottle from the kitchen", places)
    assert reading.kind == "ask"
    assert reading.question is not None
    assert reading.question.mode == "confirm"
    assert reading.question.actions == [
        Action("fetch", "kitchen", "mug"),
        Action("fetch", "kitchen", "bottle"),
    ]
    assert reading.question.text == (
        "Do you want me to get the mug from the kitchen, then get the bottle from the kitchen? "
        "(yes or no)"
    )


def test_one_answer_to_where_from_fills_every_thing_that_lacked_a_place(
    understanding: Understanding, places: PlaceIndex
) -> None:
    reading = understanding.understand("get the mug and the bottle", places)
    question = reading.question
    assert question is not None
    assert question.mode == "fill"
    assert question.text.startswith("Where should I get the mug and the bottle from?")

    answered = understanding.follow_up(question, "the kitchen", places)

    assert answered is not None
    assert answered.kind == "act"
    assert answered.actions == [
        Action("fetch", "kitchen", "mug"),
        Action("fetch", "kitchen", "bottle"),
    ]


def test_a_drive_then_a_fetch_there_is_one_fetch_from_that_place(
    understanding: Understanding, places: PlaceIndex
) -> None:
    reading = understanding.understand(
        "From the kitchen, bring a white plate to the meeting room.", places
    )
    assert reading.question is not None
    assert reading.question.actions == [Action("fetch", "kitchen", "white plate", "meeting_room")]


@pytest.mark.parametrize(
    "said",
    [
        "forget reception, head straight to Bob's desk",
        "get the mug and the bottle",
        "bring a white plate to the meeting room",
    ],
)
def test_a_fetch_without_a_place_is_asked_where_from_never_said_back_with_a_hole(
    understanding: Understanding, places: PlaceIndex, said: str
) -> None:
    reading = understanding.understand(said, places)
    words = reading.question.text if reading.question is not None else reading.text
    assert " from ?" not in words, words
    assert " from ," not in words, words
    if reading.question is not None and reading.question.mode == "confirm":
        assert all(a.place for a in reading.question.actions if a.kind == "fetch"), words


def test_no_sentence_of_any_set_is_said_back_with_an_empty_place(
    understanding: Understanding, places: PlaceIndex
) -> None:
    holes = []
    for path in DATA_SETS:
        for text, _ in load_set(path):
            question = understanding.understand(text, places).question
            if question is None or question.mode != "confirm":
                continue
            if any(a.kind == "fetch" and not a.place for a in question.actions):
                holes.append((text, question.text))
    assert len(DATA_SETS) >= 7
    assert holes == []


@pytest.mark.parametrize(
    "said",
    [
        "bring the mug and the bottle from the kitchen to reception",
        "get the mug and the bottle from the kitchen and bring them to reception",
        "get the mug and the bottle from the kitchen and bring both to reception",
    ],
)
def test_two_things_brought_to_one_place_are_each_brought_there(
    understanding: Understanding, places: PlaceIndex, said: str
) -> None:
    reading = understanding.understand(said, places)
    assert reading.question is not None
    assert reading.question.actions == [
        Action("fetch", "kitchen", "mug", "reception"),
        Action("fetch", "kitchen", "bottle", "reception"),
    ]
    assert reading.question.text == (
        "Do you want me to get the mug from the kitchen and bring it to the reception desk, "
        "then get the bottle from the kitchen and bring it to the reception desk? (yes or no)"
    )


def test_it_after_two_things_is_only_the_last_and_is_said_back_so(
    understanding: Understanding, places: PlaceIndex
) -> None:
    said = "get the mug and the bottle from the kitchen and bring it to reception"
    reading = understanding.understand(said, places)
    assert reading.question is not None
    assert reading.question.actions == [
        Action("fetch", "kitchen", "mug"),
        Action("fetch", "kitchen", "bottle", "reception"),
    ]
