"""What a hypothesis asks for (``kind_of``): anything the typed path would read as a motion is
a motion, so the spoken layer reads it back when the recognizer is unsure (issue 36)."""

from __future__ import annotations

import pytest

from robot_language.scoring import OFFICE_LIST_LOCATIONS
from robot_voice_chat.services.speech.vocabulary import Vocabulary, kind_of, places_from_listing

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
    ],
)
def test_the_other_kinds_are_unchanged(heard: str, kind: str) -> None:
    assert kind_of(heard, OFFICE) == kind
