"""The forms of a question about the past, each read into its episodic call: where the robot
was ("where were you at 3 pm"), when it last saw a thing ("when did you last see the mug"),
what it saw ("what did you see 30 seconds ago"), where it went, and what happened ("while I was
away", "in the last 10 minutes"). The server resolves every time: only relative strings
(``-45s``) and the clock text as said (``3pm``) are passed, never an absolute time."""

from __future__ import annotations

import re
from typing import Any

from robot_language.recall.cleaning import clean, typos_fixed
from robot_language.recall.phrasings import PHRASINGS
from robot_language.recall.question import LAST_SEEN, POSE_AT, WHAT_HAPPENED, Recall, RecallKind
from robot_language.recall.slots import object_of, place_of
from robot_language.recall.times import (
    BETWEEN,
    RECENT,
    TODAY,
    ago,
    clock,
    clock_range,
    said_clock,
    span,
)

FIRST_OF = 20  # "when did you first see X": the earliest of its last this-many sightings
AROUND = "5m"  # "what did you see at 3 pm": the server's "3pm -5m" to "3pm +5m"
DEFAULT_AWAY = "-1h"  # "while I was away" when the previous turn is not known
FORMS = PHRASINGS.forms
_LAST_HOUR = ("-1h", "in the last hour")


def read_recall(text: str) -> Recall | None:
    """The question about the past in ``text``, or None (not one, or not sure); a typo in the
    question word or the verb ("wher did you see", "did you sea") is read past when the
    question reads no other way."""
    plain = clean(text)
    if not plain:
        return None
    recall = _read(plain)
    if recall is None and (fixed := typos_fixed(plain)) != plain:
        recall = _read(fixed)
    return recall


def default_recall() -> Recall:
    """The digest since the person's previous turn (else the last hour): "while I was away", and
    what a question about the past that only the meaning matcher understood gets."""
    arguments = {"start": DEFAULT_AWAY, "max_items": 100}
    return Recall("away", WHAT_HAPPENED, arguments, "while away", since_turn=True)


def _read(plain: str) -> Recall | None:
    for reader in (pose_at, last_seen, _seen, _visits, _digest):
        recall = reader(plain)
        if recall is not None:
            return recall
    return None


def pose_at(text: str) -> Recall | None:
    """ "where were you at 3 pm / 10 minutes ago"."""
    if not FORMS.pose_at.search(text):
        return None
    if (at := clock(text)) is not None:
        return Recall("pose_at", POSE_AT, {"time": at}, f"at {at}")
    if (before := ago(text)) is not None:
        seconds, said = before
        return Recall("pose_at", POSE_AT, {"time": f"-{seconds}s"}, said)
    return None


def last_seen(text: str) -> Recall | None:
    """ "when did you last see the mug", "is my mug still in the kitchen", "where's the mug"."""
    still = FORMS.is_still.match(text)
    phrase = None
    if still is not None:
        rest = still["rest"]
        phrase = still["obj"] if rest == "there" else f"{still['obj']} {rest}"
    for pattern in FORMS.last_seen:
        if phrase is not None:
            break
        if (match := pattern.search(text)) is not None:
            phrase = match["obj"]
    now = FORMS.where_now.match(text) if phrase is None else None
    if now is not None:
        phrase = now["obj"]
    if phrase is None:
        return None
    obj, place = object_of(phrase)
    if obj is None:
        return None
    obj = PHRASINGS.same_thing.get(obj, obj)
    arguments: dict[str, Any] = {"query": obj}
    if place is not None:
        arguments["place"] = place
    first = bool(re.search(r"\bfirst\b", text))
    if first:
        arguments["n"] = FIRST_OF
    offer = now is not None
    return Recall("last_seen", LAST_SEEN, arguments, obj=obj, place=place, first=first, offer=offer)


def _seen(text: str) -> Recall | None:
    if not (
        FORMS.seen.search(text)
        or (FORMS.anything_at.search(text) and place_of(text) and _in_the_past(text))
    ):
        return None
    return window(text, ["sightings"], "seen", default=_LAST_HOUR)


def _in_the_past(text: str) -> bool:
    """A time in the past is said: an amount ago, the last N, a clock time, today, earlier."""
    return bool(
        FORMS.past_mark.search(text) or ago(text) or span(text) or clock(text)
        or TODAY.search(text) or RECENT.search(text) or BETWEEN.search(text)
    )  # fmt: skip


def _visits(text: str) -> Recall | None:
    if not FORMS.visits.search(text):
        return None
    return window(text, ["places"], "visits", default=_LAST_HOUR)


def _digest(text: str) -> Recall | None:
    if FORMS.away.search(text):
        return default_recall()
    if not FORMS.digest.search(text):
        return None
    return window(text, None, "digest", default=None) or default_recall()


def window(
    text: str, kinds: list[str] | None, kind: RecallKind, default: tuple[str, str] | None
) -> Recall | None:
    """The time range a question names: "N ago" (a window around it), "in the last N", "today";
    else ``default`` (start, how it is said)."""
    place = place_of(text)
    arguments: dict[str, Any] = {"max_items": 100}
    if kinds is not None:
        arguments["kinds"] = kinds
    if place is not None:
        arguments["place"] = place
    between = BETWEEN.search(text)
    if between is not None:
        start, end = clock_range(between["a"], between["b"])
        arguments["start"], arguments["end"] = start, end
        return Recall(kind, WHAT_HAPPENED, arguments, f"between {start} and {end}", place=place)
    length = span(text)
    before = ago(text) if length is None else None
    if FORMS.away.search(text):
        arguments["start"] = DEFAULT_AWAY
        return Recall(kind, WHAT_HAPPENED, arguments, "while away", place=place, since_turn=True)
    if length is not None:
        seconds, said = length
        arguments["start"] = f"-{seconds}s"
    elif before is not None:
        seconds, said = before
        half = max(15, seconds // 2)  # a window around the moment asked about
        arguments["start"] = f"-{seconds + half}s"
        if seconds - half > 0:
            arguments["end"] = f"-{seconds - half}s"
        said = f"around {said}"
    elif (at := clock(text)) is not None:  # "at 3 pm": 5 minutes either side of it
        arguments["start"], arguments["end"] = f"{at} -{AROUND}", f"{at} +{AROUND}"
        said = f"around {said_clock(at)}"
        return Recall(kind, WHAT_HAPPENED, arguments, said, place=place, around=True)
    elif TODAY.search(text):
        arguments["start"], said = "00:00", "today"
    elif RECENT.search(text):
        arguments["start"], said = "-10m", "in the last 10 minutes"
    elif place is not None and kind == "seen":  # "what was in the kitchen": the last day there
        arguments["start"], said = "-24h", "in the last 24 hours"
    elif default is not None:
        arguments["start"], said = default
    else:
        return None
    return Recall(kind, WHAT_HAPPENED, arguments, said, place=place)
