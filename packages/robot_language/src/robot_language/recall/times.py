"""Times in questions about the past, in the form the episodic server reads: amounts ("30
seconds ago", "a couple of minutes ago", "in the last half hour", "today") and clock times ("at
3 pm" → ``3pm``, "half past two" → ``2:30pm``, "between 3:30 and 3:35 pm"). Numbers said as
words are read by text_to_num (MIT); the amounts it does not read ("a few") are data."""

from __future__ import annotations

import re

from text_to_num import text2num  # type: ignore[import-untyped]

from robot_language.normalise import ONES, TEENS, TENS
from robot_language.recall.phrasings import PHRASINGS

_AMOUNTS = "|".join(sorted(map(re.escape, PHRASINGS.amounts), key=len, reverse=True))
NUMBER = rf"(?:\d+|(?:{TENS})(?:[ -](?:{ONES}))?|{TEENS}|{ONES}|{_AMOUNTS})"
UNIT = r"(?:seconds?|secs?|s|minutes?|mins?|m|hours?|hrs?|h)"
UNIT_S = {"s": 1, "m": 60, "h": 3600}
AGO = re.compile(
    rf"\b(?:(?P<half>half an? (?:hour|minute))|(?P<n>{NUMBER})\s*(?P<unit>{UNIT}))\s+ago\b"
    r"|\b(?P<moment>just now|a moment ago|a second ago|a few seconds ago|a little while ago)\b"
)
SPAN = re.compile(
    rf"\b(?:in|during|over|within|for|from)?\s*the\s+(?:last|past|previous)\s+"
    rf"(?:(?P<half>half an? hour|half hour)|(?P<quarter>quarter (?:of an )?hour)"
    rf"|(?:(?P<n>{NUMBER})\s*)?(?P<unit>{UNIT}))\b"
)
TODAY = re.compile(r"\b(?:today|this morning|this afternoon|so far today)\b")
RECENT = re.compile(r"\b(?:recently|lately|of late)\b")


def number(said: str) -> int:
    """ "30", "forty five", "twenty-five", "a couple of" as a number."""
    if said.isdigit():
        return int(said)
    return PHRASINGS.amounts.get(said) or int(text2num(said, "en"))


def seconds_of(n: str, unit: str) -> int:
    """ "5", "minutes" → 300."""
    return number(n) * UNIT_S[unit[0]]


def ago(text: str) -> tuple[int, str] | None:
    """Seconds before now, and how it was said ("30 seconds ago")."""
    match = AGO.search(text)
    if match is None:
        return None
    if match["moment"]:
        return 10, "just now"
    if match["half"]:
        seconds = 1800 if "hour" in match["half"] else 30
    else:
        seconds = seconds_of(match["n"], match["unit"])
    return seconds, f"{amount(seconds)} ago"


def span(text: str) -> tuple[int, str] | None:
    """The length of "the last N" said, and how it is restated ("in the last 10 minutes")."""
    match = SPAN.search(text)
    if match is None:
        return None
    if match["half"] or match["quarter"]:
        seconds = 1800 if match["half"] else 900
    else:
        seconds = seconds_of(match["n"] or "1", match["unit"])
    return seconds, f"in the last {spoken(seconds)}"


def amount(seconds: int) -> str:
    """ "an hour", "a minute", "2 hours", "90 seconds"."""
    return {60: "a minute", 3600: "an hour"}.get(seconds) or spoken(seconds)


def spoken(seconds: int) -> str:
    """ "hour", "minute", "2 hours", "90 seconds"."""
    if seconds % 3600 == 0:
        hours = seconds // 3600
        return "hour" if hours == 1 else f"{hours} hours"
    if seconds % 60 == 0:
        minutes = seconds // 60
        return "minute" if minutes == 1 else f"{minutes} minutes"
    return f"{seconds} seconds"


# clock times, as said and as the server reads them
CLOCK = re.compile(
    r"\b(?:at|around|about|by)?\s*(?P<clock>\d{1,2}(?::\d{2})?\s*(?:am|pm|a\.m\.|p\.m\.)"
    r"|\d{1,2}:\d{2}|noon|midday|midnight)(?![\w:])"
)
BETWEEN = re.compile(
    r"\b(?:between|from)\s+(?P<a>\d{1,2}(?::\d{2})?(?:\s*(?:am|pm))?)\s+(?:and|to|till|until)\s+"
    r"(?P<b>\d{1,2}(?::\d{2})?(?:\s*(?:am|pm))?)(?![\w:])"
)
_HOUR = rf"(?:1[0-2]|0?[1-9]|{ONES}|ten|eleven|twelve)"
_DAYPART = r"(?=\s+in the (?:morning|afternoon|evening))"
# "half past two", "ten past four", "twenty to three", "25 minutes past 3", "quarter of five",
# "four o'clock", "3 pm", "three in the afternoon", "9:15 in the evening"; not a range ("from
# ten to eleven") and not a duration ("five to ten minutes ago")
SPOKEN_CLOCK = re.compile(
    rf"(?<!from )(?<!between )\b(?:(?P<part>half|quarter|twenty[- ]five|twenty|ten|five"
    rf"|(?P<digits>[1-5]?\d))(?P<unit> minutes?)? (?P<rel>past|after|to|till|til|before|of)"
    rf" (?P<h>{_HOUR})(?:\s*(?P<m1>am|pm))?"
    rf"|(?P<h2>{_HOUR}) o'?clock|(?P<h3>{_HOUR}) (?P<m3>am|pm)"
    rf"|(?P<h4>{_HOUR}){_DAYPART}|(?P<h6>{_HOUR}):(?P<m6>[0-5]\d){_DAYPART})\b"
    r"(?!\s*(?:minutes?|mins?|hours?|hrs?|seconds?|secs?|times|[hms])\b)"
    r"(?:\s+in the (?P<daypart>morning|afternoon|evening))?"
)
_MERIDIEM = {"morning": "am", "afternoon": "pm", "evening": "pm"}


def clock_digits(match: re.Match[str]) -> str:
    """A :data:`SPOKEN_CLOCK` match as digits ("half past two" → ``2:30``), else as said."""
    hour_text = match["h"] or match["h2"] or match["h3"] or match["h4"] or match["h6"]
    hour = int(hour_text) if hour_text.isdigit() else int(text2num(hour_text, "en"))
    minute = int(match["m6"] or 0)
    if match["rel"]:
        part, rel = match["part"], match["rel"]
        if (rel == "of" and part != "quarter") or (
            match["digits"] and not match["unit"] and rel not in ("past", "after")
        ):  # "two of three", "10 to 11": not a clock time
            return match[0]
        if match["digits"]:
            minute = int(part)
        else:  # "half", "quarter", "ten", "twenty-five"
            minute = {"half": 30, "quarter": 15}.get(part) or int(text2num(part, "en"))
        if not 0 < minute < 60:
            return match[0]
        if rel in ("to", "till", "til", "before", "of"):
            hour, minute = (hour - 2) % 12 + 1, 60 - minute
    meridiem = match["m1"] or match["m3"] or _MERIDIEM.get(match["daypart"] or "", "")
    return f"{hour}:{minute:02d}{meridiem}" if minute or not meridiem else f"{hour}{meridiem}"


def clock(text: str) -> str | None:
    """The clock time as said, in a form the server reads (``3pm``, ``15:30``, ``12:00``)."""
    match = CLOCK.search(text)
    if match is None:
        return None
    said = match["clock"].replace(".", "").replace(" ", "")
    return meridiem({"noon": "12:00", "midday": "12:00", "midnight": "00:00"}.get(said, said))


def said_clock(time: str) -> str:
    """``3pm`` → ``3 pm``, ``2:30pm`` → ``2:30 pm``, ``15:30`` as is."""
    return re.sub(r"(\d)(am|pm)$", r"\1 \2", time)


def meridiem(time: str) -> str:
    """A 12-hour clock said without am/pm ("half past two", "2:30") is read as people at work
    mean it: 1 to 7 and 12 in the afternoon, 8 to 11 in the morning. The answer restates the
    time the server used, so the reading is visible."""
    match = re.fullmatch(r"(\d{1,2}):(\d{2})", time)
    if match is None:
        return time
    hour = int(match[1])
    if not 1 <= hour <= 12 or match[1].startswith("0"):
        return time
    return f"{time}{'am' if 8 <= hour <= 11 else 'pm'}"


def clock_range(a: str, b: str) -> tuple[str, str]:
    """ "3:30 and 3:35 pm": the am/pm said once holds for both ends."""
    a, b = a.replace(" ", ""), b.replace(" ", "")
    said = re.search(r"(am|pm)$", b)
    if said and not re.search(r"(am|pm)$", a):
        a += said[1]
    return _full(a), _full(b)


def _full(time: str) -> str:
    return meridiem(time if ":" in time or time[-2:] in ("am", "pm") else f"{time}:00")
