"""Short follow-ups read against the question about the past before them, inside the language
package (the brain's tests drive the same through its chat): a step back, another time, another
place, another thing; and what is left unread is never guessed."""

from __future__ import annotations

from typing import Any

import pytest

from robot_language.recall import (
    LAST_SEEN,
    POSE_AT,
    WHAT_HAPPENED,
    follow_up_recall,
    looks_like_recall,
    read_recall,
)

PLACES = ("reception", "kitchen", "mailroom")


def _follow(first: str, then: str) -> Any:
    previous = read_recall(first)
    assert previous is not None
    return follow_up_recall(then, previous, lambda phrase: phrase in PLACES)


@pytest.mark.parametrize(
    ("first", "then", "tool", "arguments", "said"),
    [
        ("what happened in the last 30 minutes", "and before that?", WHAT_HAPPENED,
         {"max_items": 100, "start": "-3600s", "end": "-1800s"}, "30 minutes earlier"),
        ("what did you see 10 minutes ago", "and an hour before that?", WHAT_HAPPENED,
         {"max_items": 100, "kinds": ["sightings"], "start": "-4500s", "end": "-3900s"},
         "an hour earlier"),
        ("where were you at 4:31 pm", "and an hour before that?", POSE_AT,
         {"time": "4:31pm -3600s"}, "an hour before 4:31 pm"),
        ("where were you an hour ago", "and before that?", POSE_AT, {"time": "-7200s"},
         "2 hours ago"),
        ("where were you at 3 pm", "what about 2:24 pm?", POSE_AT, {"time": "2:24pm"},
         "at 2:24pm"),
        ("when did you last see the mug", "and the laptop?", LAST_SEEN, {"query": "laptop"}, ""),
        ("when did you last see the mug", "where was that?", LAST_SEEN, {"query": "mug"}, ""),
        ("when did you last see the mug", "what about the kitchen?", LAST_SEEN,
         {"query": "mug", "place": "kitchen"}, ""),
        ("what did you see today", "what about the reception?", WHAT_HAPPENED,
         {"max_items": 100, "kinds": ["sightings"], "start": "00:00", "place": "reception"},
         "today"),
        ("what did you see 10 minutes ago", "and in the mailroom?", WHAT_HAPPENED,
         {"max_items": 100, "kinds": ["sightings"], "place": "mailroom", "start": "-900s",
          "end": "-300s"}, "around 10 minutes ago"),
    ],
)  # fmt: skip
def test_a_follow_up_is_read_against_the_question_before_it(
    first: str, then: str, tool: str, arguments: dict[str, Any], said: str
) -> None:
    recall = _follow(first, then)
    assert recall is not None
    assert (recall.tool, recall.arguments, recall.said) == (tool, arguments, said)


@pytest.mark.parametrize(
    ("first", "then"),
    [
        ("what happened while I was away", "and before that?"),  # no length to step back by
        ("where were you at 3 pm", "and before that?"),
        ("where were you at 3 pm", "what about the kitchen?"),  # not guessed
        ("when did you last see the mug", "and in the kitchen?"),
        ("when did you last see the mug", "tell me a joke"),
    ],
)
def test_a_follow_up_with_nothing_to_read_against_is_not_guessed(first: str, then: str) -> None:
    assert _follow(first, then) is None


@pytest.mark.parametrize(
    ("text", "unread"),
    [("and before that?", True), ("tell me a joke", False), ("", False)],
)
def test_an_unread_question_about_the_past_is_told_apart(text: str, unread: bool) -> None:
    assert looks_like_recall(text) is unread
