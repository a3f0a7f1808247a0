"""Requests made of several parts (issue 32): a round said a number of times ("patrol the kitchen
and reception twice": the legs in order, again), a patrol or a shuttle between places ("patrol
between the dock and reception", "go back and forth between X and Y"), and the extra objects
of one search ("look for the scissors and a yellow package in the mailroom")."""

from __future__ import annotations

from robot_language.config_file import patterns

MAX_ROUNDS = 5  # more rounds than this in one request are asked about, never driven
_P = patterns("composites", "times", "patrol", "list_split")
_SMALL = {"once": 1, "twice": 2, "thrice": 3, "one": 1, "two": 2, "three": 3, "a couple of": 2}


def rounds(text: str) -> tuple[str, int]:
    """``text`` without its "twice" / "3 times", and how many times it was asked for (1)."""
    match = _P["times"].search(text)
    if match is None:
        return text, 1
    said = match["word"] or match["n"]
    count = _SMALL[said] if said in _SMALL else int(said)
    return text[: match.start()].strip(" ,"), max(count, 1)


def patrol(text: str) -> str:
    """ "patrol the kitchen and reception" → "go to the kitchen, then go to reception"."""
    match = _P["patrol"].match(text)
    if match is None:
        return text
    places = [p for p in _P["list_split"].split(match["places"]) if p.strip()]
    return ", then ".join(f"go to {p.strip()}" for p in places)
