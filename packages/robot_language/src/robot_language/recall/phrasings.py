"""The phrasings the grammar of questions about the past reads as data (``config/recall.yaml``):
plain lower-case words, validated once on import; a broken file is refused with its line."""

from __future__ import annotations

from typing import Annotated

from pydantic import Field, PositiveInt, StringConstraints

from robot_language.config_file import CONFIG, Regex, Strict, read_model

RECALL_PHRASINGS = CONFIG / "recall.yaml"
# the text is read lower case with single spaces: anything else would never be matched
Words = Annotated[str, StringConstraints(pattern=r"^[a-z']+(?: [a-z']+)*$")]
WordList = Annotated[list[Words], Field(min_length=1)]


class SeeingForms(Strict):
    base: WordList
    both: WordList
    past: WordList


class Forms(Strict):
    away: Regex
    last_seen: list[Regex]
    where_now: Regex
    is_still: Regex
    seen: Regex
    anything_at: Regex
    past_mark: Regex
    digest: Regex
    pose_at: Regex
    visits: Regex


class RecallPhrasings(Strict):
    shorthand: dict[Words, Words]
    run_together: dict[Words, Words]
    opening_words: WordList
    verbs: WordList
    seeing_forms: SeeingForms
    same_thing: dict[Words, Words]
    nothing: WordList
    hedges: WordList
    amounts: dict[Words, PositiveInt]
    forms: Forms


PHRASINGS = read_model(RECALL_PHRASINGS, RecallPhrasings, "recall phrasings")
