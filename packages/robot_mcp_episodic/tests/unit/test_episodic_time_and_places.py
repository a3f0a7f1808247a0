"""Times and places resolved by the server."""

from __future__ import annotations

from datetime import UTC, datetime
from pathlib import Path
from zoneinfo import ZoneInfo

import pytest

from robot_mcp_episodic.config import EpisodicConfig, local_zone_name
from robot_mcp_episodic.places import Places, UnknownPlaceError
from robot_mcp_episodic.timeparse import (
    TimeError,
    ago,
    clock_time,
    duration,
    iso,
    local_clock,
    parse_time,
)

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


BERLIN = ZoneInfo("Europe/Berlin")


def utc(*args: int) -> float:
    return datetime(*args, tzinfo=UTC).timestamp()  # type: ignore[misc]


def test_clock_times_are_the_sites_local_time() -> None:
    now = utc(2026, 11, 24, 16, 30)  # 17:30 in Berlin (CET, UTC+1)
    assert parse_time("3 pm", now, BERLIN) == utc(2026, 11, 24, 14, 0)
    assert parse_time("3pm", now, BERLIN) == utc(2026, 11, 24, 14, 0)
    assert parse_time("15:00", now, BERLIN) == utc(2026, 11, 24, 14, 0)
    assert parse_time("17:45", now, BERLIN) == utc(2026, 11, 23, 16, 45)  # later: yesterday
    # Just after local midnight, UTC is still on the previous day: "today" is the site's.
    early = utc(2026, 11, 24, 23, 30)  # 00:30 on the 25th in Berlin
    assert parse_time("0:15", early, BERLIN) == utc(2026, 11, 24, 23, 15)
    assert parse_time("2026-11-24T15:00:00", now, BERLIN) == utc(2026, 11, 24, 15, 0)  # UTC


def test_a_clock_time_across_the_spring_change_uses_that_days_offset() -> None:
    # Berlin went from CET (+1) to CEST (+2) at 02:00 local on 2026-03-29.
    now = utc(2026, 3, 29, 8, 0)  # 10:00 CEST
    assert parse_time("3 pm", now, BERLIN) == utc(2026, 3, 28, 14, 0)  # yesterday, CET
    assert parse_time("9:00", now, BERLIN) == utc(2026, 3, 29, 7, 0)  # today, CEST
    assert parse_time("1:30", now, BERLIN) == utc(2026, 3, 29, 0, 30)  # today, still CET
    with pytest.raises(TimeError, match="clocks went forward"):
        parse_time("2:30", now, BERLIN)  # the clocks skipped it today


def test_a_clock_time_the_autumn_change_repeated_is_the_later_one_already_past() -> None:
    # Berlin went from CEST (+2) back to CET (+1) at 03:00 local on 2026-10-25: 02:30 twice.
    now = utc(2026, 10, 25, 11, 0)
    assert parse_time("2:30", now, BERLIN) == utc(2026, 10, 25, 1, 30)  # the second 02:30
    between = utc(2026, 10, 25, 1, 0)  # 02:00 CET, after the first 02:30 only
    assert parse_time("2:30", between, BERLIN) == utc(2026, 10, 25, 0, 30)
    assert parse_time("3 pm", now, BERLIN) == utc(2026, 10, 24, 13, 0)  # yesterday, CEST


def test_local_clock_texts() -> None:
    assert local_clock(utc(2026, 11, 24, 14, 0), BERLIN) == "2026-11-24 15:00:00 CET"
    assert local_clock(utc(2026, 7, 1, 14, 0), BERLIN) == "2026-07-01 16:00:00 CEST"
    assert clock_time(utc(2026, 11, 24, 14, 0), BERLIN) == "15:00 CET"


def test_the_time_zone_setting_defaults_to_the_machines_and_refuses_unknown_names(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    env = {"EPISODIC_DIR": str(tmp_path)}
    assert EpisodicConfig.from_env(env).timezone == local_zone_name()
    config = EpisodicConfig.from_env({**env, "EPISODIC_TIMEZONE": "America/New_York"})
    assert config.zone == ZoneInfo("America/New_York")
    with pytest.raises(ValueError, match="unknown time zone 'Mars/Olympus'"):
        EpisodicConfig.from_env({**env, "EPISODIC_TIMEZONE": "Mars/Olympus"})
    monkeypatch.setenv("TZ", "Asia/Tokyo")
    import tzlocal.unix

    monkeypatch.setattr(tzlocal.unix, "_cache_tz_name", None)
    assert local_zone_name() == "Asia/Tokyo"


@pytest.mark.parametrize("text", ["yesterday-ish", "-10x", "25:00", "13pm", "soon", "10"])
def test_unreadable_times_name_the_accepted_forms(text: str) -> None:
    with pytest.raises(TimeError, match=r"ISO 8601|clock time"):
        parse_time(text, NOW)


@pytest.mark.parametrize(
    ("text", "offset"),
    [
        ("3pm -5m", -5400.0 - 300), ("3 pm +5m", -5400.0 + 300), ("15:00 +10m", -5400.0 + 600),
        ("15:00+10m", -5400.0 + 600), ("2026-11-24T15:00:00Z -30s", -5400.0 - 30),
        ("2026-11-24T16:00:00+01:00 + 1 h", -5400.0 + 3600), ("now -5m", -300.0),
        ("-1h +10 min", -3000.0), ("2 hours ago - 30 seconds", -7230.0), ("3PM -1.5M", -5490.0),
    ],
)  # fmt: skip
def test_any_time_takes_one_offset(text: str, offset: float) -> None:
    assert parse_time(text, NOW) == NOW + offset


def test_an_offset_applies_to_the_clock_time_in_the_sites_zone() -> None:
    now = utc(2026, 11, 24, 16, 30)
    assert parse_time("3 pm -5m", now, BERLIN) == utc(2026, 11, 24, 13, 55)
    assert parse_time("3 pm +5m", now, BERLIN) == utc(2026, 11, 24, 14, 5)
    assert parse_time("2026-11-24T15:00:00-05:00", now) == utc(2026, 11, 24, 20, 0)  # a zone


@pytest.mark.parametrize(
    ("text", "says"),
    [
        ("3pm +5x", "offset"), ("3pm -5", "offset"), ("3pm +", "offset"),
        ("3pm -5m +1m", "one offset only"), ("soon -5m", "the time before the offset"),
        ("25:00 +5m", "not a clock time"), ("+5m", "ISO 8601"),
    ],
)  # fmt: skip
def test_bad_offsets_say_what_is_wrong_and_the_forms(text: str, says: str) -> None:
    with pytest.raises(TimeError, match=says) as caught:
        parse_time(text, NOW)
    assert "3pm -5m" in str(caught.value) or "clock time" in str(caught.value)


def test_iso_ago_and_duration_texts() -> None:
    assert iso(NOW) == "2026-11-24T16:30:00.000Z"
    assert ago(NOW - 42, NOW) == "42 s ago"
    assert ago(NOW - 600, NOW) == "10 min ago"
    assert ago(NOW - 3 * 3600 - 300, NOW) == "3 h 5 min ago"
    assert ago(NOW - 7200, NOW) == "2 h ago"
    assert ago(NOW - 2 * 86400 - 4 * 3600, NOW) == "2 d 4 h ago"
    assert ago(NOW - 86400, NOW) == "1 d ago"
    assert ago(NOW + 5, NOW) == "just now"
    assert ago(NOW - 0.4, NOW) == "just now"  # issue 31: never "0 s ago"
    assert ago(NOW - 1, NOW) == "1 s ago"
    assert duration(90) == "90 s"
    assert duration(0.3) == "less than a second"  # never "for 0 s"


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


@pytest.mark.parametrize("text", ["-99999999999d", "-99999999999999999999s", "-1h -99999999999d"])
def test_a_time_no_calendar_can_show_is_a_time_error(text: str) -> None:
    """Issue 31: it raised a bare ValueError from datetime (the tool answered "internal")."""
    with pytest.raises(TimeError, match="out of range"):
        parse_time(text, NOW)
