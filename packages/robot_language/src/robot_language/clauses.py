"""Splitting a request into its legs and reading each leg's slots from the words."""

from __future__ import annotations

import re

from robot_language.normalise import normalise

_SPLIT = re.compile(
    r"\s*(?:[,;]\s*(?:and\s+)?(?:then|after\s+that|afterwards|next)\b"
    r"|[.!?]\s+(?:and\s+)?(?:then\s+)?"
    r"|\s+and\s+(?:then|after\s+that|afterwards)\b"
    r"|\s+(?:then|after\s+that|afterwards)\b"
    r"|;|,\s*(?:and\s+)?|\s+and\s+)\s*"
)
_LEAD = re.compile(
    r"^(?:(?:please|robot|hey robot|ok|okay|now|then|and|first|firstly|next|finally|also|"
    r"could you|can you|would you|will you|i want you to|i'd like you to|i would like you to|"
    r"i need you to)[\s,]+)+"
)
_TRAIL = re.compile(
    r"(?:\s+(?:please|now|right now|for me|for us|anywhere|around here|anywhere around here|"
    r"here|around|somewhere|again))+$"
)
_REPORT = re.compile(r"^(?:tell|report|let)\s+(?:me|us)\s*(?:back|know)?$")
_ARTICLE = re.compile(r"^(?:the|a|an|my|our|some|her|his|their|your|any|this|that)\s+")


def clauses(text: str) -> list[str]:
    """The legs of a request in order ("go to the kitchen, then reception" → 2)."""
    parts = [tidy(p) for p in _SPLIT.split(normalise(text, spoken=False).strip(" .!?"))]
    return [p for p in parts if p and not _REPORT.match(p)]


def tidy(part: str) -> str:
    part = part.strip(" ,.!?;:")
    part = _LEAD.sub("", part)
    return _TRAIL.sub("", part).strip(" ,.!?")


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


_SEARCH_IN = re.compile(
    r"^(?:search|check|look\s+in|look\s+through|go\s+through)\s+(?P<place>.+?)\s+for\s+(?P<obj>.+)$"
)
_OBJ_IN = re.compile(r"^(?P<obj>.+?)\s+(?:is\s+|are\s+)?(?:in|at|inside|on)\s+(?P<place>.+)$")
_FETCH = re.compile(
    r"^(?P<obj>.+?)\s+(?:from|at|in|out\s+of)\s+(?P<place>.+?)"
    r"(?:\s+(?:and\s+)?(?:bring|take|deliver|carry|drop)?\s*(?:it|them)?\s*(?:off\s+)?to\s+(?P<to>.+))?$"
)
_DELIVER = re.compile(r"^(?:it|them|that|this|those)\s+(?:off\s+)?(?:to|at)\s+(?P<to>.+)$")
_WATCH_TAIL = re.compile(r"\s+(?:appears?|shows?\s+up|turns?\s+up|is\s+visible|comes?\s+by)$")
_THERE = re.compile(r"^(?:there(?:'s| is| are)|there)\s+")
_FOR = re.compile(r"^.*?\s+for\s+(?P<obj>.+)$")


def find_slots(text: str, verbs: list[str]) -> tuple[str | None, str | None]:
    """(object, place phrase) of a find/search leg."""
    match = _SEARCH_IN.match(text)
    if match is not None:
        return strip_article(match["obj"]) or None, strip_article(match["place"])
    rest, _ = without_verb(text, verbs)
    rest = _THERE.sub("", rest)  # "check if there's a package"
    match = _OBJ_IN.match(rest)
    if match is not None:
        return strip_article(match["obj"]) or None, strip_article(match["place"])
    return strip_article(rest) or None, None


def fetch_slots(text: str, verbs: list[str]) -> tuple[str | None, str | None, str | None]:
    """(object, from place, to place) of a fetch leg."""
    rest, _ = without_verb(text, verbs)
    rest = re.sub(r"^(?:me|us)\s+", "", rest)
    match = _FETCH.match(rest)
    if match is None:
        return strip_article(rest) or None, None, None
    to = strip_article(match["to"]) if match["to"] else None
    return strip_article(match["obj"]) or None, strip_article(match["place"]), to


def deliver_slot(text: str, verbs: list[str]) -> str | None:
    rest, _ = without_verb(text, verbs)
    match = _DELIVER.match(rest)
    return strip_article(match["to"]) or None if match is not None else None


def watch_slot(text: str, verbs: list[str]) -> str | None:
    rest, _ = without_verb(text, verbs)
    rest = re.sub(r"^(?:you\s+)?(?:see|spot)\s+", "", rest)
    match = _FOR.match(rest)
    if match is not None and not rest.startswith(("someone", "somebody")):
        rest = match["obj"]
    return strip_article(_WATCH_TAIL.sub("", rest)) or None
