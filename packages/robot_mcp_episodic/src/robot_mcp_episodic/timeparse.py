"""Times as people and planners write them, resolved by the server (the model never does time
arithmetic): ISO 8601 (``2026-11-24T15:00:00Z``; no zone = UTC), a clock time today
(``15:00``, ``3pm``, ``3 pm``) read in the site's time zone, relative (``-30s``, ``-10m``,
``-2h``, ``-1d``, ``30 s ago``) and ``now``; any of them with one offset after it
(``3pm -5m``, ``15:00 +10m``, ``2026-11-24T15:00:00Z -30s``), so "around 3 pm" is a window the
planner can pass as said (``3pm -5m`` to ``3pm +5m``).

Clock times follow the zone's rules on the day meant (a "3 pm" asked the morning after the
clocks changed is yesterday's 3 pm at yesterday's offset); a wall time that happened twice
(clocks going back) is the later one that is not in the future; one the clocks skipped is a
clear error.
"""

from __future__ import annotations

import re
from datetime import UTC, date, datetime, timedelta
from datetime import time as wall_time
from zoneinfo import ZoneInfo, ZoneInfoNotFoundError

_UNITS = r"(s|sec|secs|seconds?|m|min|mins|minutes?|h|hr|hrs|hours?|d|days?)"
_RELATIVE = re.compile(rf"^\s*-\s*(\d+(?:\.\d+)?)\s*{_UNITS}\s*$")
_AGO = re.compile(rf"^\s*(\d+(?:\.\d+)?)\s*{_UNITS}\s+ago\s*$")
# "<time> ± <duration>": the time is anything non-empty before the sign (so "-10m" alone stays
# a relative time, and an ISO zone such as "-05:00" is no offset: it has no unit)
_OFFSET = re.compile(
    rf"^\s*(?P<base>\S.*?)\s*(?P<sign>[+-])\s*(?P<n>\d+(?:\.\d+)?)\s*(?P<unit>{_UNITS})\s*$",
    re.IGNORECASE,
)
_DANGLING = re.compile(r"\s[+-]\s*\S*$")  # "3pm +", "3pm -5", "3pm +5x": an offset misread
_CLOCK = re.compile(r"^\s*(\d{1,2})(?::(\d{2}))?\s*(am|pm)?\s*$")
_UNIT_S = {"s": 1.0, "m": 60.0, "h": 3600.0, "d": 86400.0}


UTC_ZONE = ZoneInfo("UTC")


class TimeError(ValueError):
    """A time the server cannot read; the message says which forms it accepts."""


def site_zone(name: str) -> ZoneInfo:
    """The IANA zone ``name`` (``Europe/Berlin``); ValueError naming it when unknown."""
    try:
        return ZoneInfo(name)
    except (ZoneInfoNotFoundError, ValueError):
        raise ValueError(
            f"unknown time zone {name!r}: use an IANA name such as Europe/Berlin or UTC"
        ) from None


def _unit(text: str) -> float:
    return _UNIT_S[text[0]]


def parse_time(text: str | float | None, now: float, zone: ZoneInfo = UTC_ZONE) -> float:
    """Unix seconds for ``text`` relative to ``now`` (unix s); clock times are read in
    ``zone``. ``None`` or empty = now. One offset may follow any time (``3pm -5m``). A time
    no calendar date can show (``-99999999999d``) is a :class:`TimeError`, like any other."""
    return _on_the_calendar(_parse_time(text, now, zone), text)


def _on_the_calendar(stamp: float, text: object) -> float:
    try:
        datetime.fromtimestamp(stamp, UTC)
    except (OverflowError, OSError, ValueError):
        raise TimeError(
            f"the time {text!r} is out of range: give a time between the years 1 and 9999"
        ) from None
    return stamp


def _parse_time(text: str | float | None, now: float, zone: ZoneInfo) -> float:
    if text is None:
        return now
    if isinstance(text, int | float):
        return float(text)
    offset = _OFFSET.match(text)
    if offset is None:
        if _DANGLING.search(text.strip()):
            raise TimeError(f"cannot read the offset in {text!r}: {_OFFSET_FORMS}")
        return _base(text, now, zone)
    base = offset["base"]
    if _OFFSET.match(base) or not base.strip(" +-"):
        raise TimeError(f"cannot read the time {text!r}: one offset only. {_OFFSET_FORMS}")
    seconds = float(offset["n"]) * _unit(offset["unit"].lower())
    try:
        stamp = _base(base, now, zone)
    except TimeError as exc:
        raise TimeError(f"{exc} (in {text!r}: the time before the offset)") from None
    return stamp + seconds if offset["sign"] == "+" else stamp - seconds


_FORMS = (
    "use ISO 8601 (2026-11-24T15:00:00Z), a relative time (-30s, -10m, -2h, -1d), a clock "
    "time today (15:00, 3pm, 3 pm; the site's local time) or now, optionally followed by one "
    "offset (3pm -5m, 15:00 +10m, 2026-11-24T15:00:00Z -30s)"
)
_OFFSET_FORMS = (
    "an offset is a sign and a duration after the time (3pm -5m, 15:00 +10m, "
    "2026-11-24T15:00:00Z -30s; units s, m, h, d)"
)


def _base(text: str, now: float, zone: ZoneInfo) -> float:
    """A time without an offset."""
    value = text.strip().lower()
    if value in ("", "now"):
        return now
    for pattern in (_RELATIVE, _AGO):
        match = pattern.match(value)
        if match:
            return now - float(match.group(1)) * _unit(match.group(2))
    clock = _CLOCK.match(value)
    if clock and (clock.group(2) is not None or clock.group(3) is not None):
        return _clock_today(clock, now, zone)
    try:
        parsed = datetime.fromisoformat(text.strip().replace("Z", "+00:00").replace("z", "+00:00"))
    except ValueError:
        raise TimeError(f"cannot read the time {text!r}: {_FORMS}") from None
    if parsed.tzinfo is None:
        parsed = parsed.replace(tzinfo=UTC)
    return parsed.timestamp()


def _clock_today(match: re.Match[str], now: float, zone: ZoneInfo) -> float:
    said = match.group(0).strip()
    hour = int(match.group(1))
    minute = int(match.group(2) or 0)
    meridiem = match.group(3)
    if meridiem:
        if not 1 <= hour <= 12:
            raise TimeError(f"{said!r} is not a clock time")
        hour = hour % 12 + (12 if meridiem == "pm" else 0)
    if hour > 23 or minute > 59:
        raise TimeError(f"{said!r} is not a clock time")
    wanted = wall_time(hour, minute)
    today = datetime.fromtimestamp(now, zone).date()
    happened = _occurrences(today, wanted, zone)
    if not happened and _instant(today, wanted, zone, fold=0) <= now:
        raise TimeError(
            f"{said!r} did not happen on {today.isoformat()} in {zone.key}: the clocks went "
            "forward over it; ask for a time just before or after"
        )
    # "3 pm" said at 10 am means yesterday's 3 pm: memory answers about the past.
    past = [t for t in happened if t <= now]
    if past:
        return max(past)
    earlier = _occurrences(today - timedelta(days=1), wanted, zone)
    if not earlier:
        raise TimeError(
            f"{said!r} did not happen yesterday in {zone.key}: the clocks went forward over it"
        )
    return max(earlier)


def _instant(day: date, wanted: wall_time, zone: ZoneInfo, fold: int) -> float:
    return datetime.combine(day, wanted, tzinfo=zone).replace(fold=fold).timestamp()


def _occurrences(day: date, wanted: wall_time, zone: ZoneInfo) -> list[float]:
    """The instants the wall clock showed ``wanted`` on ``day`` in ``zone``: one, two when
    the clocks went back over it, none when they went forward over it."""
    found = []
    for fold in (0, 1):
        stamp = _instant(day, wanted, zone, fold)
        back = datetime.fromtimestamp(stamp, zone)
        if back.date() == day and back.time() == wanted and stamp not in found:
            found.append(stamp)
    return found


def clock_time(stamp: float, zone: ZoneInfo) -> str:
    """``16:00 CET``: the site's time of day at ``stamp``."""
    return datetime.fromtimestamp(stamp, zone).strftime("%H:%M %Z")


def local_clock(stamp: float, zone: ZoneInfo) -> str:
    """``2026-11-24 16:00:00 CET``: the site's wall clock at ``stamp``."""
    return datetime.fromtimestamp(stamp, zone).strftime("%Y-%m-%d %H:%M:%S %Z")


def iso(stamp: float) -> str:
    """``2026-11-24T15:00:00.123Z`` (UTC, milliseconds)."""
    text = datetime.fromtimestamp(stamp, UTC).isoformat(timespec="milliseconds")
    return text.replace("+00:00", "Z")


def ago(stamp: float, now: float) -> str:
    """``"just now"`` (under a second), ``"42 s ago"``, ``"5 min ago"``, ``"3 h 5 min ago"``,
    ``"2 d 4 h ago"``."""
    seconds = max(0, round(now - stamp))
    if seconds < 1:
        return "just now"
    if seconds < 120:
        return f"{seconds} s ago"
    minutes = seconds // 60
    if minutes < 60:
        return f"{minutes} min ago"
    hours, minutes = divmod(minutes, 60)
    if hours < 24:
        return f"{hours} h {minutes} min ago" if minutes else f"{hours} h ago"
    days, hours = divmod(hours, 24)
    return f"{days} d {hours} h ago" if hours else f"{days} d ago"


def duration(seconds: float) -> str:
    """``"less than a second"``, ``"45 s"``, ``"12 min"``, ``"1 h 30 min"``."""
    if round(seconds) < 1:
        return "less than a second"
    return ago(0.0, max(0.0, seconds)).removesuffix(" ago")
