"""Times and places resolved by the server."""

from __future__ import annotations

from datetime import UTC, datetime

import pytest

from robot_mcp_episodic.places import Places, UnknownPlaceError
from robot_mcp_episodic.timeparse import TimeError, ago, duration, iso, parse_time

NOW = datetime(2026, 11, 24, 16, 30, tzinfo=UTC).timestamp()


@pytest.mark.parametrize(
    ("text", "offset"),
    [
        ("now", 0.0), ("", 0.0), (None, 0.0), ("-30s", -30.0), ("-10m", -600.0),
        ("-2h", -7200.0), ("-1d", -86400.0), ("- 5 min", -300.0), ("-1.5h", -5400.0),
        ("30 s ago", -30.0), ("2 hours ago", -7200.0), ("NOW", 0.0),
    ],
)  # fmt: skip
def test_relative_times_and_now(text: str | None, offset: float) -> None:
    assert parse_time(text, NOW) == NOW + offset


def test_iso_times_with_and_without_zone() -> None:
    assert parse_time("2026-11-24T15:00:00Z", NOW) == NOW - 5400
    assert parse_time("2026-11-24T15:00:00", NOW) == NOW - 5400  # no zone = UTC
    assert parse_time("2026-11-24T16:00:00+01:00", NOW) == NOW - 5400
    assert parse_time(NOW - 5.0, NOW) == NOW - 5.0


def test_clock_times_today_or_yesterday() -> None:
    assert parse_time("15:00", NOW) == NOW - 5400
    assert parse_time("3pm", NOW) == NOW - 5400
    assert parse_time("3 pm", NOW) == NOW - 5400
    assert parse_time("12am", NOW) == NOW - 16.5 * 3600
    assert parse_time("17:00", NOW) == NOW - 86400 + 1800  # later today = yesterday


@pytest.mark.parametrize("text", ["yesterday-ish", "-10x", "25:00", "13pm", "soon", "10"])
def test_unreadable_times_name_the_accepted_forms(text: str) -> None:
    with pytest.raises(TimeError, match=r"ISO 8601|clock time"):
        parse_time(text, NOW)


def test_iso_ago_and_duration_texts() -> None:
    assert iso(NOW) == "2026-11-24T16:30:00.000Z"
    assert ago(NOW - 42, NOW) == "42 s ago"
    assert ago(NOW - 600, NOW) == "10 min ago"
    assert ago(NOW - 3 * 3600 - 300, NOW) == "3 h 5 min ago"
    assert ago(NOW - 7200, NOW) == "2 h ago"
    assert ago(NOW - 2 * 86400 - 4 * 3600, NOW) == "2 d 4 h ago"
    assert ago(NOW - 86400, NOW) == "1 d ago"
    assert ago(NOW + 5, NOW) == "0 s ago"
    assert duration(90) == "90 s"


def test_places_locate_within_the_radius(places: Places) -> None:
    assert places.map == "office"
    assert places.locate(9.2, -3.1) == "kitchen"
    assert places.locate(4.0, 1.5) == "reception"
    assert places.locate(12.0, 1.0) is None  # between places
    assert places.position("front desk") == (4.0, 1.5)


def test_places_resolve_names_and_aliases(places: Places) -> None:
    assert places.resolve("Meeting Room") == "meeting_room"
    assert places.resolve("front-desk") == "reception"
    assert places.resolve("mail room") == "mailroom"
    with pytest.raises(UnknownPlaceError, match="known places: dock, reception"):
        places.resolve("garage")
