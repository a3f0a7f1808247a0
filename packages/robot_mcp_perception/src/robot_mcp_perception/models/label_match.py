"""Tolerant matching of a free-text query against object labels.

"the red mug on the left" finds "red mug": the query and labels are tokenised (lower case,
plural ``s`` stripped, a few synonyms folded), stop words and spatial words are ignored,
and a label matches when its head noun (last word) is in the query and no colour in the
query contradicts it. Spatial words (left/right/top/bottom/biggest/smallest) then pick one
instance among several matches.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Sequence
from typing import TypeVar

T = TypeVar("T")

STOP_WORDS = frozenset(
    [
        "a",
        "an",
        "the",
        "of",
        "on",
        "in",
        "at",
        "to",
        "with",
        "and",
        "or",
        "for",
        "from",
        "is",
        "are",
        "be",
        "it",
        "its",
        "this",
        "that",
        "these",
        "those",
        "there",
        "here",
        "some",
        "any",
        "find",
        "locate",
        "show",
        "me",
        "please",
        "segment",
        "detect",
        "point",
        "where",
        "which",
        "what",
        "lying",
        "sitting",
        "standing",
        "placed",
        "near",
        "next",
        "by",
        "up",
        "down",
        "side",
        "pile",
    ]
)
SPATIAL_WORDS = frozenset(
    [
        "left",
        "leftmost",
        "right",
        "rightmost",
        "top",
        "topmost",
        "upper",
        "bottom",
        "lower",
        "middle",
        "center",
        "centre",
        "biggest",
        "largest",
        "big",
        "large",
        "smallest",
        "small",
        "little",
    ]
)
GENERIC_WORDS = frozenset(
    [
        "object",
        "thing",
        "item",
        "instance",
        "everything",
        "anything",
        "all",
        "every",
        "each",
        "distinct",
        "visible",
    ]
)
COLOURS = frozenset(
    [
        "red",
        "blue",
        "green",
        "yellow",
        "white",
        "black",
        "orange",
        "grey",
        "gray",
        "brown",
        "purple",
        "pink",
        "silver",
    ]
)
SYNONYMS = {
    "cup": "mug",
    "parcel": "package",
    "carton": "box",
    "flask": "bottle",
    "dish": "plate",
    "shear": "scissors",
    "shears": "scissors",
    "gray": "grey",
}
_KEEP_S = frozenset({"scissors", "glass", "this", "is", "its"})


def tokens(text: str) -> list[str]:
    out = []
    for word in re.findall(r"[a-z0-9]+", text.lower()):
        if word.endswith("ies") and len(word) > 4:
            word = word[:-3] + "y"
        elif word.endswith("es") and word[:-2].endswith(("x", "ch", "sh")):
            word = word[:-2]
        elif word.endswith("s") and not word.endswith("ss") and word not in _KEEP_S:
            word = word[:-1]
        out.append(SYNONYMS.get(word, word))
    return out


def content_tokens(text: str) -> set[str]:
    return {t for t in tokens(text) if t not in STOP_WORDS and t not in SPATIAL_WORDS}


def is_generic(query: str) -> bool:
    """True when the query names no particular thing ("every object", "anything", "")."""
    return content_tokens(query) <= GENERIC_WORDS


def label_score(query: str, label: str) -> int:
    """How well ``label`` answers ``query``: 0 = no match, else the number of shared words."""
    q = content_tokens(query)
    lt = tokens(label)
    if not lt or lt[-1] not in q:
        return 0
    if (q & COLOURS) - set(lt):
        return 0
    return len(q & set(lt))


def select(
    query: str,
    items: Sequence[T],
    label_of: Callable[[T], str],
    position_of: Callable[[T], tuple[float, float]],
    area_of: Callable[[T], float],
) -> list[T]:
    """The items the query refers to (all of them for a generic query).

    With several matches, a spatial word narrows them to one: left/right/top/bottom by
    position, biggest/smallest by area.
    """
    if is_generic(query):
        matches = list(items)
    else:
        scores = [label_score(query, label_of(it)) for it in items]
        best = max(scores, default=0)
        matches = [it for it, s in zip(items, scores, strict=True) if best > 0 and s == best]
    if len(matches) < 2:
        return matches
    words = set(tokens(query))
    pickers: list[tuple[frozenset[str], Callable[[T], float]]] = [
        (frozenset({"left", "leftmost"}), lambda it: position_of(it)[0]),
        (frozenset({"right", "rightmost"}), lambda it: -position_of(it)[0]),
        (frozenset({"top", "topmost", "upper"}), lambda it: position_of(it)[1]),
        (frozenset({"bottom", "lower"}), lambda it: -position_of(it)[1]),
        (frozenset({"biggest", "largest", "big", "large"}), lambda it: -area_of(it)),
        (frozenset({"smallest", "small", "little"}), area_of),
    ]
    for trigger, key in pickers:
        if words & trigger:
            return [min(matches, key=key)]
    return matches
