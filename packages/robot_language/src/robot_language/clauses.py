"""Splitting a request into its legs and reading each leg's slots from the words."""

from __future__ import annotations

import re

from robot_language.config_file import patterns
from robot_language.normalise import normalise

_P = patterns("clauses", "split", "lead", "trail", "report", "search_in", "obj_in", "fetch",
              "deliver", "put_it", "watch_tail", "there", "for")  # fmt: skip
SEARCH_IN = _P["search_in"]
PUT_IT = _P["put_it"]

_ARTICLE = re.compile(r"^(?:the|a|an|my|our|some|her|his|their|your|any|this|that)\s+")


def clauses(text: str) -> list[str]:
    """The legs of a request in order ("go to the kitchen, then reception" → 2)."""
    parts = [tidy(p) for p in _P["split"].split(normalise(text, spoken=False).strip(" .!?"))]
    return [p for p in parts if p and not _P["report"].match(p)]


def tidy(part: str) -> str:
    part = part.strip(" ,.!?;:")
    part = _P["lead"].sub("", part)
    return _P["trail"].sub("", part).strip(" ,.!?")


def strip_article(phrase: str) -> str:
    phrase = phrase.strip(" ,.!?")
    while (cut := _ARTICLE.sub("", phrase)) != phrase:
        phrase = cut
    return phrase


def without_verb(text: str, verbs: list[str]) -> tuple[str, bool]:
    """``text`` without its leading verb phrase (the longest of ``verbs`` that starts it)."""
    for verb in sorted(verbs, key=len, reverse=True):
        if text == verb:
            return "", True
        if text.startswith(verb + " "):
            return text[len(verb) + 1 :], True
    return text, False


def find_slots(text: str, verbs: list[str]) -> tuple[str | None, str | None]:
    """(object, place phrase) of a find/search leg."""
    match = SEARCH_IN.match(text)
    if match is not None:
        return strip_article(match["obj"]) or None, strip_article(match["place"])
    rest, _ = without_verb(text, verbs)
    rest = _P["there"].sub("", rest)  # "check if there's a package"
    match = _P["obj_in"].match(rest)
    if match is not None:
        return strip_article(match["obj"]) or None, strip_article(match["place"])
    return strip_article(rest) or None, None


def fetch_slots(text: str, verbs: list[str]) -> tuple[str | None, str | None, str | None]:
    """(object, from place, to place) of a fetch leg."""
    rest, _ = without_verb(text, verbs)
    rest = re.sub(r"^(?:me|us)\s+", "", rest)
    match = _P["fetch"].match(rest)
    if match is None:
        return strip_article(rest) or None, None, None
    to = strip_article(match["to"]) if match["to"] else None
    return strip_article(match["obj"]) or None, strip_article(match["place"]), to


def deliver_slot(text: str, verbs: list[str]) -> str | None:
    rest, _ = without_verb(text, verbs)
    match = _P["deliver"].match(rest)
    return strip_article(match["to"]) or None if match is not None else None


def watch_slot(text: str, verbs: list[str]) -> str | None:
    rest, _ = without_verb(text, verbs)
    rest = re.sub(r"^(?:you\s+)?(?:see|spot)\s+", "", rest)
    match = _P["for"].match(rest)
    if match is not None and not rest.startswith(("someone", "somebody")):
        rest = match["obj"]
    return strip_article(_P["watch_tail"].sub("", rest)) or None
