from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from robot_mcp_kit.poster import EventPoster, PosterClosedError


@pytest.mark.parametrize(
    ("url", "server", "secret", "options", "message"),
    [
        ("ftp://x/events", "nav", "s", {}, "http"),
        ("/api/agent/events", "nav", "s", {}, "http"),
        ("http://127.0.0.1:1/e", "", "s", {}, "server"),
        ("http://127.0.0.1:1/e", "nav", "", {}, "secret"),
        ("http://127.0.0.1:1/e", "nav", "s", {"max_outbox": 0}, "max_outbox"),
        ("http://127.0.0.1:1/e", "nav", "s", {"backoff_max_s": 0.01}, "backoff"),
        ("http://127.0.0.1:1/e", "nav", "s", {"request_timeout_s": 0}, "timeouts"),
    ],
)
def test_bad_poster_settings_fail_at_construction(
    tmp_path: Path, url: str, server: str, secret: str, options: dict[str, Any], message: str
) -> None:
    with pytest.raises(ValueError, match=message):
        EventPoster(url, server, secret, tmp_path / "o.sqlite", **options)


async def test_a_poster_starts_once_and_closing_twice_is_harmless(tmp_path: Path) -> None:
    never_started = EventPoster("http://127.0.0.1:1/e", "nav", "s", tmp_path / "n.sqlite")
    await never_started.close()
    with pytest.raises(PosterClosedError):
        await never_started.start()

    async with EventPoster("http://127.0.0.1:1/e", "nav", "s", tmp_path / "o.sqlite") as poster:
        with pytest.raises(PosterClosedError):
            await poster.start()
    await poster.close()

    unreachable = EventPoster("http://127.0.0.1:1/e", "nav", "s", tmp_path / "o.sqlite")
    await unreachable.start()
    await unreachable.emit("t", "tool", "progress", {})
    assert unreachable.pending_count() == 1
    await unreachable.close(flush_timeout_s=0.1)
    stats = unreachable.stats()
    assert (stats["emitted"], stats["delivered"], stats["pending"]) == (1, 0, 1)
