"""What a hypothesis asks for (``kind_of``): anything the typed path would read as a motion is
a motion, so the spoken layer reads it back when the recognizer is unsure (issue 36)."""

from __future__ import annotations

import pytest

from robot_language.scoring import OFFICE_LIST_LOCATIONS
from robot_voice_chat.services.speech.vocabulary import (
    Vocabulary,
    addressed,
    is_sentence,
    is_stop,
    kind_of,
    matcher,
    places_from_listing,
    rules,
)

OFFICE = Vocabulary.build(places_from_listing(OFFICE_LIST_LOCATIONS))


@pytest.mark.parametrize(
    "heard",
    [
        "the east corridor",  # the benchmark heard "give me a description of the room" so
        "please the meeting room",  # ... and "visit reception then the garden" so
        "kitchen",
        "robot the bob's desk please",
        "go to the kitchen",
        "fetch the package from the mailroom and bring it to reception",
    ],
)
def test_a_place_named_without_a_verb_is_a_motion(heard: str) -> None:
    assert kind_of(heard, OFFICE) == "motion"


@pytest.mark.parametrize(
    ("heard", "kind"),
    [
        ("yes", "answer"),
        ("the second one", "answer"),
        ("stop", "stop"),
        ("what time is it", "other"),
        ("don't go to the kitchen", "other"),
        ("don't go to the kitchen go to reception", "motion"),
        ("resume please", "motion"),  # a paused mission drives on: read back when unsure
        ("carry on", "motion"),
        ("continue the mission", "motion"),
    ],
)
def test_the_other_kinds_are_unchanged(heard: str, kind: str) -> None:
    assert kind_of(heard, OFFICE) == kind


def test_a_wake_phrase_is_heard_as_an_opener_and_taken_off() -> None:
    listing = places_from_listing(OFFICE_LIST_LOCATIONS)
    with_wake = Vocabulary.build(listing, wake="Hey  Computer")
    grammar = rules(with_wake)
    assert with_wake.wake == "hey computer"
    assert with_wake.digest() != OFFICE.digest()  # a new wake phrase rebuilds the grammar
    assert is_sentence("hey computer go to the kitchen", matcher(grammar))
    assert not is_sentence("hey computer", matcher(grammar))
    assert kind_of("hey computer go to the kitchen", with_wake) == "motion"
    assert kind_of("hey computer stop", with_wake) == "stop"
    assert addressed("ok robbie, go to the kitchen", "Robbie") == ("go to the kitchen", True)
    assert addressed("robbie's mug is in the kitchen", "robbie") == (
        "robbie's mug is in the kitchen",
        False,
    )
    assert addressed("go to the kitchen robbie", "robbie") == ("go to the kitchen robbie", False)
    assert is_stop("halt right there")
    assert is_stop("stop")
    assert not is_stop("don't stop")
