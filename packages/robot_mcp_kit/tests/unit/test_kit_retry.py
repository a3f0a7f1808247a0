from __future__ import annotations

import random
from datetime import UTC, datetime
from email.utils import format_datetime

from hypothesis import given
from hypothesis import strategies as st

from robot_mcp_kit.retry import backoff_delay, parse_retry_after


@given(
    attempt=st.integers(0, 10_000),
    initial=st.floats(0.001, 5),
    factor=st.floats(1, 100),
    seed=st.integers(),
)
def test_backoff_stays_between_half_and_all_of_the_capped_exponential_step(
    attempt: int, initial: float, factor: float, seed: int
) -> None:
    maximum = initial * factor
    step = min(maximum, initial * 2 ** min(attempt, 60))
    delay = backoff_delay(attempt, initial, maximum, random.Random(seed))
    assert step / 2 <= delay <= step


def test_backoff_grows_until_the_cap() -> None:
    rng = random.Random(1)
    lows = [backoff_delay(n, 0.1, 10, rng) for n in range(12)]
    assert lows[0] <= 0.1
    assert lows[3] >= 0.4
    assert max(lows) <= 10


def test_retry_after_reads_seconds_and_http_dates() -> None:
    assert parse_retry_after("3") == 3.0
    assert parse_retry_after(" 0.5 ") == 0.5
    assert parse_retry_after("-4") == 0.0
    when = datetime(2030, 1, 1, 0, 0, 10, tzinfo=UTC)
    now = datetime(2030, 1, 1, 0, 0, 0, tzinfo=UTC).timestamp()
    assert parse_retry_after(format_datetime(when, usegmt=True), now=now) == 10.0
    assert parse_retry_after(format_datetime(when, usegmt=True), now=now + 60) == 0.0


def test_unreadable_retry_after_values_are_ignored() -> None:
    for value in (None, "", "soon", "nan", "inf", "Mon, 99 Foo 2030"):
        assert parse_retry_after(value) is None
