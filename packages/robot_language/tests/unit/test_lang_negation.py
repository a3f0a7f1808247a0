"""Negations and corrections (issue 32): the negated place is never driven to, never proposed
and never part of a "Did you mean" reading."""

from __future__ import annotations

import pytest

from robot_language import negation
from robot_language.reading import Reading
from robot_language.scoring import OFFICE_LIST_LOCATIONS
from robot_language.understand import Understanding

PLACES = {"kitchen", "mailroom", "reception", "the kitchen", "the mailroom", "the dock", "dock"}


def _is_place(phrase: str) -> bool:
    return phrase in PLACES


@pytest.mark.parametrize(
    ("said", "text", "negated"),
    [
        ("don't go to the kitchen, go to reception instead", "go to reception", ["kitchen"]),
        ("don't go to the kitchen go to reception", "go to reception", ["kitchen"]),
        ("not the kitchen, the mailroom", "the mailroom", ["kitchen"]),
        ("go to the mailroom instead of the kitchen", "go to the mailroom", ["kitchen"]),
        ("go to reception rather than the kitchen", "go to reception", ["kitchen"]),
        ("go to the kitchen not reception", "go to the kitchen", ["reception"]),
        ("go to the kitchen no wait the mailroom", "go to the mailroom", ["kitchen"]),
        ("go to the kitchen, actually the dock", "go to the dock", ["kitchen"]),
        ("go to the kitchen, sorry, i mean the mailroom", "go to the mailroom", ["kitchen"]),
        ("actually go to the mailroom", "go to the mailroom", []),
        ("wait for someone to arrive", "wait for someone to arrive", []),
        ("is there no parcel here", "is there no parcel here", []),
    ],
)
def test_negations_and_corrections_are_taken_apart(
    said: str, text: str, negated: list[str]
) -> None:
    read = negation.read(said, _is_place)
    assert read.text == text
    assert read.negated == negated


def test_only_a_negation_leaves_nothing_to_do() -> None:
    read = negation.read("don't go to the kitchen", _is_place)
    assert read.only_negative
    assert read.refused == "go to the kitchen"


def _places(understanding: Understanding):  # type: ignore[no-untyped-def]
    return understanding.places(OFFICE_LIST_LOCATIONS)


def _mentions(reading: Reading, name: str) -> bool:
    actions = [*reading.actions, *(reading.question.actions if reading.question else [])]
    options = reading.question.options if reading.question else []
    text = reading.question.text if reading.question else ""
    return (
        any(name in (a.place, a.to) for a in actions)
        or name in options
        or name.replace("_", " ") in text
    )


@pytest.mark.parametrize(
    ("said", "codes", "never"),
    [
        ("don't go to the kitchen, go to reception instead", ["goto:reception"], "kitchen"),
        ("go to the kitchen no wait the mailroom", ["goto:mailroom"], "kitchen"),
        ("dont go to the kichen go to the mailroom", ["goto:mailroom"], "kitchen"),
        ("go to reception no the kitchen", ["goto:kitchen"], "reception"),
        ("not the kitchen", ["cancel"], "kitchen"),
        ("don't go to the kitchen", ["cancel"], "kitchen"),
        ("don't go to the kitchen, go to the kichen", ["refuse"], "kitchen"),
        ("is the mug not in the kitchen", ["refuse"], "kitchen"),
        ("go to the kitchen and then reception, no wait, the mailroom",
         ["goto:kitchen", "goto:mailroom"], "reception"),
        # skip / avoid (issue 38): before, "go to the kitchen, then the reception desk?"
        ("skip the kitchen and go straight to reception", ["goto:reception"], "kitchen"),
        ("avoid the mailroom and head to the dock", ["goto:dock"], "mailroom"),
        ("stay away from the kitchen", ["cancel"], "kitchen"),
    ],
)  # fmt: skip
def test_a_negated_place_is_never_driven_to_or_proposed(
    understanding: Understanding, said: str, codes: list[str], never: str
) -> None:
    reading = understanding.understand(said, _places(understanding))
    assert reading.code() == codes
    assert not _mentions(reading, never)


def test_a_pure_negation_says_what_it_will_not_do(understanding: Understanding) -> None:
    reading = understanding.understand("please dont go to bobs desk", _places(understanding))
    assert reading.kind == "cancel"
    assert reading.text == "OK, I won't go to Bob's desk."


def test_no_and_a_place_answers_a_question_with_that_place(understanding: Understanding) -> None:
    places = _places(understanding)
    question = understanding.understand("go to the kitchenette", places).question
    assert question is not None
    answer = understanding.follow_up(question, "no, the mailroom", places)
    assert answer is not None
    assert answer.code() == ["goto:mailroom"]
    cancelled = understanding.follow_up(question, "no", places)
    assert cancelled is not None
    assert cancelled.kind == "cancel"


def test_a_thing_to_be_left_alone_is_never_handled(understanding: Understanding) -> None:
    # before: "put the red mug alone down, then go to the kitchen?"
    said = "leave the red mug alone, just tell me whether it's in the kitchen"
    reading = understanding.understand(said, _places(understanding))
    assert not any(code.startswith(("put", "pick", "fetch")) for code in reading.code())
    proposed = reading.question.actions if reading.question is not None else reading.actions
    assert not any(a.kind in ("put", "pick", "fetch") for a in proposed)


def test_skip_to_a_place_is_not_a_negation() -> None:
    assert negation.read("skip to the mailroom", _is_place).negated == []
