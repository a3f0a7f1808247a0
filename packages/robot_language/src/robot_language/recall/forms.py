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
AWAY = re.compile(
    r"\b(?:while|when|whilst) i (?:was|were) (?:away|gone|out|out of the office|not here|"
    r"not around|at lunch|in a meeting|in the meeting)"
    r"|\bsince i (?:left|was (?:last )?here|went away|last (?:spoke|talked|asked|checked))"
    r"|\bsince (?:we|you and i) (?:last )?(?:spoke|talked)|\bsince my last (?:message|question)"
    r"|\bsince (?:the )?last time (?:we|i) (?:spoke|talked)|\bin my absence\b"
    r"|\bwhat did i miss\b|\bcatch me up\b|\bfill me in\b|\bbring me up to (?:date|speed)\b"
)
_SAW = r"(?:saw|spotted|noticed|have seen|'ve seen|had seen|came across|have come across)"
_SEE = r"(?:see|seen|spot|spotted|notice|noticed|come across|came across|run into)"
_LAST_SEEN = [
    # the thing moved on: "where did the scissors end up", "where has my mug got to"
    re.compile(
        r"\bwhere(?:'d| did| has| have| had) (?!(?:you|we|i|it|they|the robot)\b)(?P<obj>.+?) "
        r"(?:end(?:ed)? up|go|gone|went|get to|got to|gotten to|wind up|wound up|"
        r"disappear(?:ed)?(?: to)?|vanish(?:ed)?(?: to)?)$"
    ),
    # "the last time / place you saw X", "where's the last place you spotted X"
    re.compile(
        rf"\b(?:the )?(?:last|first) (?:time|place|spot) (?:that |where )?you {_SAW} (?P<obj>.+)"
    ),
    # the thing as subject: "when did the mug last show up", "when was the mug last seen"
    re.compile(
        r"\b(?:when|where) (?:did|was|were|has|have) (?:the last time )?(?P<obj>.+?) "
        r"(?:last |first )?(?:show(?:ed)? up|turn(?:ed)? up|appear(?:ed)?|pop(?:ped)? up)\b"
    ),
    re.compile(
        r"\b(?:the )?last time (?:that )?(?P<obj>.+?) (?:showed up|turned up|appeared|was seen)\b"
    ),
    re.compile(
        rf"\bhow (?:long|many \w+) ago (?:did|have) you (?:last |first )?{_SEE} (?P<obj>.+)"
    ),
    re.compile(
        r"\bhow long (?:did|have|were) you (?:see|seen|spot|watch|watched|looking at) (?P<obj>.+)"
    ),
    # "any idea where the charger is", "do you know where my keys went"
    re.compile(
        r"\b(?:any idea|do you know|have you any idea|got any idea|you know) where (?P<obj>.+?) "
        r"(?:is|are|was|were|went|ended up|might be|could be)\b"
    ),
    # the auxiliary dropped, as typed: "seen my keys?", "you seen the laptop anywhere"
    re.compile(r"^(?:you )?(?:seen|spotted|noticed|come across) (?P<obj>.+)"),
    re.compile(
        r"\b(?:when|where)\b(?: and (?:when|where))?(?: exactly)?\s+(?:did|have|had)\s+you\s+"
        r"(?:last|most recently|first|ever)?\s*(?:see|seen|spot|spotted|notice|noticed)\s+"
        r"(?P<obj>.+)"
    ),
    re.compile(
        r"\b(?:when|where)\b(?: and (?:when|where))?\s+you\s+(?:last\s+|most recently\s+)?"
        r"(?:saw|spotted|noticed|have seen|'ve seen)\s+(?P<obj>.+)"
    ),
    re.compile(rf"^(?:have|did|had) you (?:ever |already |recently )?{_SEE} (?P<obj>.+)"),
    re.compile(
        r"\b(?:where|when) (?:was|were|is|are) (?P<obj>.+?) (?:last |first )?(?:seen|spotted)"
    ),
    re.compile(r"\bwhere (?:did|have) (?:i|we) (?:leave|left|put) (?P<obj>.+)"),
    re.compile(r"\b(?:any|seen any) (?:sign|trace) of (?P<obj>.+)"),
]
# "where's the red mug now?", "where are the scissors": present tense, but the robot can only
# say where it last saw the thing; the answer offers to go and look (a question, never a motion)
_WHERE_NOW = re.compile(
    r"^where(?:'s| is| are|'re| r)\s+(?!(?:you|we|i|it|they|he|she|that|this|those|these|the robot|"
    r"everyone|everybody|everything|my location|your location)\b)(?P<obj>.+?)"
    r"(?:\s+(?:now|right now|at the moment|currently|then|kept|located|hiding|at))?$"
)
# "is my mug still in the kitchen": its sighting there, and whether it was gone later
_IS_STILL = re.compile(r"^(?:is|are) (?P<obj>.+?) still (?P<rest>(?:in|at|on|by|near) .+|there)$")
_SEEN = re.compile(
    r"\bwhat\s+(?:else\s+)?(?:did|have|had)\s+you\s+(?:just\s+)?(?:see|seen|spot|spotted|notice|"
    r"noticed|observe|observed|look at|looked at)\b"
    r"|\bwhat\s+(?:(?:objects|things)\s+)?you\s+(?:just\s+)?(?:saw|spotted|noticed|observed|"
    r"have seen|'ve seen)\b"
    r"|\b(?:did|have) you (?:see|seen|spot|spotted|notice|noticed) (?:anything|something|"
    r"any(?:one|body)|things)\b"
    r"|\bwhat (?:was|were) (?:in front of you|you looking at|in view|on (?:your )?camera)\b"
    r"|\bwhat (?:objects|things|stuff) (?:did|have) you (?:see|seen|spot|spotted|notice|noticed)\b"
    r"|\bwhat (?:did|had) (?:your camera|the camera|you) (?:pick up|catch|detect|see)\b"
    r"|\bwhich (?:objects|things) (?:did|have) you (?:see|seen|spot|spotted)\b"
    r"|\b(?:what )?(?:do|can) you remember (?:seeing|spotting|noticing|from|about)\b"
    r"|\bwhat (?:objects |things |stuff )?(?:was|were) (?:there |lying |standing )?"
    r"(?:in|at|on|inside) (?!front of\b)"
    r"|\bwhat (?:objects|things) (?:are|were) (?:there|around)\b"
    r"|^(?:was|were) there (?:anything|anyone|anybody|something|someone|somebody)\b"
)
# "anything at the reception earlier?", "anyone in the kitchen at 3 pm?": a digest of what was
# seen there, when a time in the past is said (without one it may be a request to go and look)
_ANYTHING_AT = re.compile(
    r"^(?:(?:and|so|but)\s+)?(?:(?:did you see|you see|see|seen|saw)\s+)?(?:anything|anyone|"
    r"anybody|something|someone|somebody)(?: (?:interesting|unusual|new|else|at all))?"
    r" (?:in|at|on|inside|near|by) "
)
_PAST_MARK = re.compile(r"\b(?:earlier|before|ago|yesterday|previously|so far)\b")
_DIGEST = re.compile(
    r"\bwhat(?:'s| has| had|'d)?\s+(?:just\s+)?(?:happened|happening|been happening|been going on|"
    r"went on|going on)\b"
    r"|\bwhat (?:did|have) you (?:do|done|been doing|been up to|get up to|got up to)\b"
    r"|\bwhat (?:were|was) you (?:doing|up to)\b"
    r"|\banything (?:happen|happened|new|interesting|going on|to report)\b"
    r"|\bdid anything (?:happen|interesting happen)\b"
    r"|\bwhat(?:'s| is) new\b|\bgive me (?:a |an )?(?:summary|recap|rundown|update)\b"
    r"|\b(?:summari[sz]e|recap)\b|\bwhat did i miss\b|\bcatch me up\b|\bfill me in\b"
    r"|\bbring me up to (?:date|speed)\b|\bwhat went on\b"
)
_POSE_AT = re.compile(
    r"\bwhere\s+(?:were|was)\s+(?:you|the robot|it)\b|\bwhich (?:room|place|location) were you"
    r"|\bwhere had you been\b|\bwhat were you (?:doing|up to)\b|\bwhere did you be\b"
)
_VISITS = re.compile(
    r"\bwhere (?:have|did) you (?:been|go|gone|drive|driven|went)\b"
    r"|\bwhich (?:places|rooms) (?:did|have) you (?:visit|visited|go to|been to|drive to)"
    r"|\bwhere all (?:have|did) you\b"
)
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
    """What a question about the past that only the meaning matcher understood gets: the
    digest since the person's previous turn (else the last hour)."""
    return _away()


def _read(plain: str) -> Recall | None:
    for reader in (pose_at, last_seen, _seen, _visits, _digest):
        recall = reader(plain)
        if recall is not None:
            return recall
    return None


def pose_at(text: str) -> Recall | None:
    """ "where were you at 3 pm / 10 minutes ago"."""
    if not _POSE_AT.search(text):
        return None
    if (at := clock(text)) is not None:
        return Recall("pose_at", POSE_AT, {"time": at}, f"at {at}")
    if (before := ago(text)) is not None:
        seconds, said = before
        return Recall("pose_at", POSE_AT, {"time": f"-{seconds}s"}, said)
    return None


def last_seen(text: str) -> Recall | None:
    """ "when did you last see the mug", "is my mug still in the kitchen", "where's the mug"."""
    still = _IS_STILL.match(text)
    phrase = None
    if still is not None:
        rest = still["rest"]
        phrase = still["obj"] if rest == "there" else f"{still['obj']} {rest}"
    for pattern in _LAST_SEEN:
        if phrase is not None:
            break
        if (match := pattern.search(text)) is not None:
            phrase = match["obj"]
    now = _WHERE_NOW.match(text) if phrase is None else None
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
        _SEEN.search(text) or (_ANYTHING_AT.search(text) and place_of(text) and _in_the_past(text))
    ):
        return None
    return window(text, ["sightings"], "seen", default=_LAST_HOUR)


def _in_the_past(text: str) -> bool:
    """A time in the past is said: an amount ago, the last N, a clock time, today, earlier."""
    return bool(
        _PAST_MARK.search(text) or ago(text) or span(text) or clock(text)
        or TODAY.search(text) or RECENT.search(text) or BETWEEN.search(text)
    )  # fmt: skip


def _visits(text: str) -> Recall | None:
    if not _VISITS.search(text):
        return None
    return window(text, ["places"], "visits", default=_LAST_HOUR)


def _digest(text: str) -> Recall | None:
    if AWAY.search(text):
        return _away()
    if not _DIGEST.search(text):
        return None
    return window(text, None, "digest", default=None) or _away()


def _away() -> Recall:
    arguments = {"start": DEFAULT_AWAY, "max_items": 100}
    return Recall("away", WHAT_HAPPENED, arguments, "while away", since_turn=True)


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
    if AWAY.search(text):
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
