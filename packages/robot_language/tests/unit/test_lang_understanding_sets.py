"""The understanding layer on the phrasing sets (written before tuning): accuracy floors per
intent and never a wrong action."""

from __future__ import annotations

from pathlib import Path

import pytest

from robot_language.scoring import (
    OFFICE_LIST_LOCATIONS,
    grammar_reader,
    is_wrong,
    load_set,
    score,
)
from robot_language.understand import Understanding

DATA = Path(__file__).parent / "data"
SPEECH_FLOOR = 0.93  # measured once at the end of issue 32 (56/60), never tuned on
# the floors reached (issue 22); a change that lowers one is a regression. find: 20/24 until
# issue 20 moved "where is the red mug" / "where's the green bottle" to answer:last_seen (the
# last sighting, then an offer to look); the same 4 misses are 18/22
FLOORS_A = {"answer": 1.0, "fetch": 0.92, "find": 0.81, "goto": 0.92, "greet": 1.0, "refuse": 0.94,
            "see": 0.9, "sequence": 1.0, "stop": 1.0, "watch": 0.9, "ask": 0.9}  # fmt: skip
TOTAL_FLOOR = {"set_a.yaml": 0.92, "set_b.yaml": 0.77,
               # issue 32: the speech-style sets (set_speech is held out: never tuned on)
               "set_speech_tuning.yaml": 0.95, "set_speech.yaml": SPEECH_FLOOR,
               # issue 38 (held out, now spent): 40/79 with the ROLES stage, 0 wrong
               "set_c.yaml": 0.5}  # fmt: skip


def _reader(understanding: Understanding):  # type: ignore[no-untyped-def]
    places = understanding.places(OFFICE_LIST_LOCATIONS)
    return lambda text: understanding.understand(text, places).code()


@pytest.mark.parametrize("name", sorted(TOTAL_FLOOR))
def test_no_wrong_action_and_the_floor_is_kept(understanding: Understanding, name: str) -> None:
    items = load_set(DATA / name)
    result = score(items, _reader(understanding))
    assert result.wrong == [], result.wrong
    assert result.understood / result.total >= TOTAL_FLOOR[name], result.misses


def test_set_a_per_intent_floors(understanding: Understanding) -> None:
    result = score(load_set(DATA / "set_a.yaml"), _reader(understanding))
    accuracy = result.intent_accuracy()
    low = {k: v for k, v in accuracy.items() if v < FLOORS_A[k]}
    assert not low, (low, result.misses)


def test_sets_are_big_enough_and_the_grammar_alone_acted_wrongly() -> None:
    set_a, set_b = load_set(DATA / "set_a.yaml"), load_set(DATA / "set_b.yaml")
    assert len(set_a) >= 150
    assert len(set_b) >= 60
    before = score(set_a, grammar_reader)
    assert before.wrong  # e.g. "go to the kitchen and then to reception" drove to reception only
    assert (
        "Go to the kitchen and then to reception",
        ["goto:kitchen", "goto:reception"],
        ["goto:reception"],
    ) in before.wrong


def test_wrong_action_definition() -> None:
    assert is_wrong(["goto:reception"], ["goto:kitchen", "goto:reception"])
    assert is_wrong(["goto:kitchen"], ["ask"])
    assert not is_wrong(["ask"], ["goto:kitchen"])
    assert not is_wrong(["watch:a person appears"], ["watch:person"])
    assert is_wrong(["find:mug@kitchen"], ["find:mug@mailroom"])


def test_the_speech_set_was_written_before_and_the_grammar_alone_read_little_of_it() -> None:
    items = load_set(DATA / "set_speech.yaml")
    assert len(items) >= 40
    before = score(items, grammar_reader)
    assert before.understood / before.total < 0.4
