"""ROLES: a carrying request read from its verb and its prepositions (issue 38 item 1).

"move the blue folder from the desk to the kitchen", "take the mug to the kitchen from the
mailroom" and "carry the box off the reception desk over to the dock" are one structure — a verb
of carrying, a thing, a source and a destination — said in any order. The words live in
``config/roles.yaml``. A reading comes out only when the structure is whole: the thing is named
and is not a place, and every source and destination phrase names a place on the live map (the
RESOLVE step then asks when one is ambiguous). Anything else is left to the other readings.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Collection
from dataclasses import dataclass
from functools import cache
from pathlib import Path

from pydantic import BaseModel, ConfigDict, Field

from robot_language.clauses import strip_article
from robot_language.config_file import CONFIG, read_model

DEFAULT_ROLES = CONFIG / "roles.yaml"


class RoleWords(BaseModel):
    model_config = ConfigDict(extra="forbid")

    carry_verbs: list[str] = Field(min_length=1)
    after_verb: list[str] = Field(default_factory=list)
    source: list[str] = Field(min_length=1)
    destination: list[str] = Field(min_length=1)
    to_the_person: list[str] = Field(default_factory=list)
    # longer verbs of other actions that start like a carrying verb ("take a trip to"): the
    # understanding layer adds every other action intent's verbs
    other_verbs: list[str] = Field(default_factory=list)
    not_things: list[str] = Field(default_factory=list)
    done_to: list[str] = Field(default_factory=list)
    asking_for: list[str] = Field(default_factory=list)
    not_in_a_thing: list[str] = Field(default_factory=list)
    conditions: list[str] = Field(default_factory=list)


@dataclass(frozen=True)
class Roles:
    thing: str
    source: str | None
    destination: str | None


@cache
def role_words(path: Path = DEFAULT_ROLES) -> RoleWords:
    return read_model(path, RoleWords, "roles")


def said_plainly(text: str, words: RoleWords) -> str:
    """A carrying request said as a condition or with its verb after the thing, as a plain one:
    "if the mug is in the kitchen, bring it to reception" → "bring the mug from the kitchen to
    reception"; "the mug from the kitchen brought to reception" → "bring the mug from ...";
    anything else unchanged."""
    verbs = _alternatives(words.carry_verbs)
    condition = re.match(
        rf"^(?:{_alternatives(words.conditions)}) (?P<thing>.+?) (?:is|are) (?:at|in|on|by) "
        rf"(?P<source>.+?),? (?:then )?(?P<verb>{verbs}) (?:it|them) (?P<rest>.+)$",
        text,
    )
    if condition is not None:
        return (
            f"{condition['verb']} {condition['thing']} from {condition['source']} "
            f"{condition['rest']}"
        )
    done = re.match(rf"^(?P<thing>.+?) (?:{_alternatives(words.done_to)}) (?P<rest>.+)$", text)
    if done is None or _after(text, words.carry_verbs) is not None:
        return text
    thing = done["thing"]
    for frame in sorted(words.asking_for, key=len, reverse=True):
        thing = thing.removeprefix(frame + " ")
    if set(thing.split()) & set(words.not_in_a_thing):
        return text  # "the meeting was moved to the kitchen": told, not asked for
    return f"bring {thing} {done['rest']}"


def read_roles(
    text: str,
    words: RoleWords,
    names_a_place: Callable[[str], bool],
    only_a_place: Callable[[str], bool] | None = None,
    people: Collection[str] = (),
) -> Roles | None:
    """The roles of a carrying request, or None when ``text`` is not one whole.
    ``names_a_place``: the phrase names (or nearly names) a place; ``only_a_place``: it is a place
    and nothing else (a thing may share a word with a place: "the parcel", "the kitchen roll");
    ``people``: whose things are theirs, not a place's ("Bob's mug" is not "from Bob's desk")."""
    is_place = only_a_place or names_a_place
    rest = _after(text, words.carry_verbs)
    other = _after(text, words.other_verbs)
    if rest is None or (other is not None and len(other) < len(rest)):
        return None  # "take a trip to the kitchen": a longer verb of another action
    rest = _skip(rest, words.after_verb)
    marks = _marks(rest, words.source, "source") + _marks(rest, words.destination, "destination")
    marks.sort()
    thing = strip_article(rest[: marks[0][0]] if marks else rest)
    found: dict[str, str] = {}
    owner, _, owned = thing.partition("'s ")
    if owned and owner not in people and is_place(owner):  # "reception's package": from there
        thing, found["source"] = owned, owner
    if not thing or thing in words.not_things or is_place(thing) or not (marks or found):
        return None
    for index, (_, end, role) in enumerate(marks):
        stop = marks[index + 1][0] if index + 1 < len(marks) else len(rest)
        phrase = rest[end:stop].strip()
        to_the_person = role == "destination" and phrase in words.to_the_person
        if role in found or not phrase or not (to_the_person or names_a_place(phrase)):
            return None  # a role said twice, or a phrase that is no place: not this structure
        found[role] = "" if to_the_person else phrase
    return Roles(thing, found.get("source"), found.get("destination") or None)


def _alternatives(phrases: list[str]) -> str:
    return "|".join(re.escape(p) for p in sorted(phrases, key=len, reverse=True))


def _after(text: str, verbs: list[str]) -> str | None:
    for verb in sorted(verbs, key=len, reverse=True):
        if text.startswith(verb + " "):
            return text[len(verb) + 1 :]
    return None


def _skip(text: str, words: list[str]) -> str:
    head, _, tail = text.partition(" ")
    return tail if head in words and tail else text


def _marks(text: str, prepositions: list[str], role: str) -> list[tuple[int, int, str]]:
    """Where each preposition of ``role`` stands in ``text`` (the longest wins at one spot)."""
    pattern = _alternatives(prepositions)
    return [(m.start(), m.end(), role) for m in re.finditer(rf"\b(?:{pattern})\b", text)]
