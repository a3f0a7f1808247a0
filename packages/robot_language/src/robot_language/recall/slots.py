"""The thing and the place a question about the past names: "the red mug in the kitchen" →
``red mug`` in ``kitchen``; a hedge ("at about 3:30") or a time is never a place."""

from __future__ import annotations

import re

from robot_language.recall.phrasings import PHRASINGS
from robot_language.recall.times import AGO, SPAN, ago, span

ARTICLE = re.compile(r"^(?:the|a|an|my|our|some|any|your|her|his|their|that|this)\s+")
_HEDGES = sorted(PHRASINGS.hedges)
_HEDGE = r"(?:" + "|".join(_HEDGES) + r"|at (?:" + "|".join(_HEDGES) + r"))\b"
_PLACE_WORDS = (
    r"(?:the\s+|my\s+|our\s+)?(?P<place>[a-z' ]+?)"
    r"(?=\s+(?:today|recently|lately|earlier|in the|during|over|this|\d|a |an |half|just|"
    r"around|when|while|between|from|before|after|at (?:\d|noon|midday|midnight)|"
    + _HEDGE
    + r")|$)"
)
_PLACE = re.compile(
    r"\b(?:in|at|inside)\s+(?!(?:the\s+)?(?:last|past|previous|moment)\b)" + _PLACE_WORDS
)
# "what's on Bob's desk": "on" names a place only in this form ("on Monday" never does)
_ON_PLACE = re.compile(r"^what(?:'s| is| are) (?:there |lying |standing )?on\s+" + _PLACE_WORDS)
_NO_PLACE = {"all", "view", "noon", "midday", "midnight", *PHRASINGS.hedges}
_PLACE_TAIL = re.compile(r"\s+(?:in|at|inside|near|by)\s+(?:the\s+|my\s+|our\s+)?(?P<place>.+)$")
_OBJECT_TAIL = re.compile(
    r"(?:\s*,?\s*(?:and|or)\s+(?:when|where|how|what|for how long)\b.*"
    r"|\s+(?:the\s+)?(?:last|first)(?:\s+time)?\b.*|\s+most recently\b.*"
    r"|\s+(?:recently|lately|before|earlier|yet|today|at all|anywhere|around|ever|"
    r"this morning|this afternoon|please|again)\b.*"
    r"|\s+(?:is|are|was|were|for)$)"
)


def place_of(text: str) -> str | None:
    """The place said after "in" / "at" ("what did you see in the kitchen at 3 pm")."""
    match = _PLACE.search(text) or _ON_PLACE.match(text)
    if match is None:
        return None
    place = match["place"].strip()
    words = place.split()
    if (
        not words
        or words[0] in _NO_PLACE
        or words[:2] in (["front"], ["front", "of"])  # "in front of you" is no place
        or ago(place)
        or span(place)
    ):
        return None
    return place


def object_of(phrase: str) -> tuple[str | None, str | None]:
    """What to look up, and the place it was asked about ("the mug in the kitchen")."""
    obj = phrase.strip(" ,.?!")
    obj = AGO.sub("", obj).strip()
    obj = SPAN.sub("", obj).strip()
    obj = _OBJECT_TAIL.sub("", obj).strip(" ,")
    place = None
    where = _PLACE_TAIL.search(obj)
    if where is not None:
        place = where["place"].strip()
        obj = obj[: where.start()].strip()
    obj = ARTICLE.sub("", obj).strip()
    obj = re.sub(r"^(?:any|one|ones)\s+", "", obj).strip()
    if not obj or obj in PHRASINGS.nothing or len(obj.split()) > 5:
        return None, None
    return obj, place
