"""Issue 20: typos in a question about the past. The grammar's own function words are read past
("wher did you see", "wat did you see"); an object's name is corrected only by the episodic
memory, against the labels it holds, and the answer says how it was read."""

from __future__ import annotations

import json

import pytest

from robot_language.recall import (
    LAST_SEEN,
    POSE_AT,
    WHAT_HAPPENED,
    looks_like_recall,
    read_recall,
)
from robot_language.understand import Understanding
from robot_voice_chat.services.llm.rules.recollection import recollection


@pytest.mark.parametrize(
    ("text", "tool"),
    [
        ("wher did you last see the laptop?", LAST_SEEN),
        ("wen did you last see the laptop", LAST_SEEN),
        ("wat did you see in the kitchen", WHAT_HAPPENED),
        ("whre were you at 3 pm", POSE_AT),
        ("when did you lst see the laptop", LAST_SEEN),
        ("wheres the laptop", LAST_SEEN),
    ],
)
def test_a_typo_in_a_function_word_is_read_past(text: str, tool: str) -> None:
    recall = read_recall(text)
    assert recall is not None, text
    assert recall.tool == tool
    if tool == LAST_SEEN:
        assert recall.arguments["query"] == "laptop"


def test_a_typo_in_an_object_name_is_left_to_the_memory() -> None:
    recall = read_recall("have you seen the scisors?")
    assert recall is not None
    assert recall.arguments == {"query": "scisors"}


@pytest.mark.parametrize(
    "text", ["go to the kitchen", "wait here", "find the mug", "what do you see"]
)
def test_requests_are_not_corrected_into_questions_about_the_past(text: str) -> None:
    assert read_recall(text) is None
    assert not looks_like_recall(text)


def test_a_typo_too_far_to_read_is_said_not_understood_never_acted_on() -> None:
    reading = Understanding().understand("hwere did you see the mug")
    assert (reading.kind, reading.actions) == ("refuse", [])


def test_the_answer_says_how_the_memory_read_a_misspelt_thing() -> None:
    recall = read_recall("have you seen the scisors?")
    data = {
        "query": "scisors", "read_as": "scissor", "found": True,
        "results": [{"label": "scissors", "place": "reception",
                     "last_seen": {"ago": "2 h ago", "time": "2026-09-21T14:26:00.000Z"}}],
    }  # fmt: skip
    assert recollection(recall, LAST_SEEN, json.dumps(data), False) == (
        "I last saw the scissors (I read 'scisors' as scissors) at the reception 2 h ago "
        "(14:26:00 UTC)."
    )
