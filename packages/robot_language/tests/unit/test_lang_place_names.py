"""A place name is never a whole unparsed sentence (issue 38 item 3): a phrase that is not on
the map is said back as "a place called ..." only when it could be a place's name."""

from __future__ import annotations

import pytest

from robot_language.places import could_name_a_place
from robot_language.scoring import OFFICE_LIST_LOCATIONS
from robot_language.understand import Understanding


@pytest.mark.parametrize(
    "sentence",
    [
        "go to the place where you were yesterday if you can",
        "head over to wherever it is you keep the spare batteries",
        "drive to what you think is the nicest room",
    ],
)
def test_a_sentence_is_not_said_back_as_a_place(
    understanding: Understanding, sentence: str
) -> None:
    reading = understanding.understand(sentence, understanding.places(OFFICE_LIST_LOCATIONS))
    assert reading.code() in (["refuse"], ["ask"])
    said = reading.question.text if reading.question else reading.text
    assert "a place called" not in said, said


def test_an_unknown_short_name_is_still_named() -> None:
    assert could_name_a_place("the garden")
    assert could_name_a_place("the big red garden shed by the gate")
    assert not could_name_a_place("how is your battery")
    assert not could_name_a_place("where you were yesterday if you can")
    assert not could_name_a_place("")


def test_an_unknown_place_is_named_with_the_places_known(understanding: Understanding) -> None:
    reading = understanding.understand(
        "go to the garden", understanding.places(OFFICE_LIST_LOCATIONS)
    )
    assert reading.code() == ["refuse"]
    assert reading.text.startswith("I don't know a place called 'garden'. I know:")
