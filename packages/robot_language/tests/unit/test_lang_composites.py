"""Composite requests (issue 32): several objects of one search, check-then-bring,
get-and-put-on, "swing by X and check if there's a Y", a round repeated in order."""

from __future__ import annotations

import pytest

from robot_language import composites
from robot_language.scoring import OFFICE_LIST_LOCATIONS
from robot_language.understand import Understanding


@pytest.mark.parametrize(
    ("said", "codes"),
    [
        ("go to the mailroom and look for scissors and a yellow package",
         ["find:scissors@mailroom", "find:yellow package@mailroom"]),
        ("find the keys and the wallet in the kitchen",
         ["find:keys@kitchen", "find:wallet@kitchen"]),
        ("first check the mailroom for the yellow package and after that bring it to alice",
         ["fetch:yellow package@mailroom>desk_alice"]),
        ("check the kitchen for the red mug and bring it to reception",
         ["fetch:red mug@kitchen>reception"]),
        ("please get the green bottle from the kitchen and put it on Bob's desk",
         ["fetch:green bottle@kitchen>desk_bob"]),
        ("grab the parcel from the mailroom and leave it at reception",
         ["fetch:parcel@mailroom>reception"]),
        ("could you please swing by the mailroom and check if there's a package",
         ["find:package@mailroom"]),
        ("patrol the kitchen and reception twice",
         ["goto:kitchen", "goto:reception", "goto:kitchen", "goto:reception"]),
        ("patrol between the dock and reception three times",
         ["goto:dock", "goto:reception"] * 3),
        ("look around and tell me what you see", ["see"]),
    ],
)  # fmt: skip
def test_composite_requests_are_read_as_their_parts_in_order(
    understanding: Understanding, said: str, codes: list[str]
) -> None:
    places = understanding.places(OFFICE_LIST_LOCATIONS)
    assert understanding.understand(said, places).code() == codes


def test_more_rounds_than_allowed_are_asked_about_not_driven(
    understanding: Understanding,
) -> None:
    places = understanding.places(OFFICE_LIST_LOCATIONS)
    reading = understanding.understand("patrol the kitchen and reception a hundred times", places)
    assert reading.kind == "ask"
    assert reading.question is not None
    assert len(reading.question.actions) == 2 * composites.MAX_ROUNDS
    assert "100 rounds" in reading.question.text


@pytest.mark.parametrize(
    ("said", "text", "rounds"),
    [("patrol the kitchen twice", "patrol the kitchen", 2),
     ("go to the dock 3 times please", "go to the dock", 3),
     ("go to the dock", "go to the dock", 1)],
)  # fmt: skip
def test_a_count_is_read_off_the_end(said: str, text: str, rounds: int) -> None:
    assert composites.rounds(said) == (text, rounds)


def test_a_did_you_mean_is_a_sentence_with_human_place_names(
    understanding: Understanding,
) -> None:
    places = understanding.places(OFFICE_LIST_LOCATIONS)
    reading = understanding.understand("swing by reception and see if there's a parcel", places)
    assert reading.question is not None
    assert reading.question.text == (
        "Do you want me to look for the parcel at the reception desk? (yes or no)"
    )
