"""Retry timing for the poster: exponential backoff with jitter, and Retry-After."""

from __future__ import annotations

import math
import random
import time
from email.utils import parsedate_to_datetime


def backoff_delay(
    attempt: int, initial_s: float, max_s: float, rng: random.Random | None = None
) -> float:
    """Delay before retry number ``attempt`` (0-based): "equal jitter" — half of the
    exponential step is fixed, the other half random — so retries spread out but never
    collapse to zero."""
    step = min(max_s, initial_s * float(2 ** min(attempt, 60)))
    jitter: float = (rng or random).uniform(0, step / 2)
    return step / 2 + jitter


def parse_retry_after(value: str | None, now: float | None = None) -> float | None:
    """Seconds to wait from a ``Retry-After`` header (delta-seconds or HTTP-date), or None
    when absent or unreadable. Never negative."""
    if value is None:
        return None
    text = value.strip()
    if not text:
        return None
    try:
        seconds = float(text)
    except ValueError:
        pass
    else:
        return max(0.0, seconds) if math.isfinite(seconds) else None
    try:
        when = parsedate_to_datetime(text)
    except (TypeError, ValueError):
        return None
    if when.tzinfo is None:
        return None
    current = time.time() if now is None else now
    return max(0.0, when.timestamp() - current)
