"""Fixtures for the poster integration tests: a real signature-checking receiver served by
uvicorn on 127.0.0.1, and posters that are always closed."""

from __future__ import annotations

from collections.abc import AsyncIterator, Callable
from pathlib import Path
from typing import Any

import pytest

from robot_mcp_kit.poster import EventPoster
from robot_stack_testing.kit.receiver import ReceiverServer, RecordingReceiver

SECRET = "kit-test-secret-\u00e9"  # non-ASCII on purpose: the key is UTF-8 encoded
SERVER = "navigation"


@pytest.fixture
def receiver() -> RecordingReceiver:
    return RecordingReceiver({SERVER: SECRET})


@pytest.fixture
async def receiver_server(
    receiver: RecordingReceiver, tcp_port: int
) -> AsyncIterator[ReceiverServer]:
    server = ReceiverServer(receiver, tcp_port)
    try:
        yield server
    finally:
        await server.stop()


@pytest.fixture
def outbox_path(tmp_path: Path) -> Path:
    return tmp_path / "outbox" / "events.sqlite"


PosterFactory = Callable[..., EventPoster]


@pytest.fixture
async def make_poster(
    receiver_server: ReceiverServer, outbox_path: Path
) -> AsyncIterator[PosterFactory]:
    """Builds posters with fast test backoff; closes every one of them at teardown."""
    posters: list[EventPoster] = []

    def make(**overrides: Any) -> EventPoster:
        options: dict[str, Any] = {
            "backoff_initial_s": 0.02,
            "backoff_max_s": 0.3,
            "request_timeout_s": 2.0,
        }
        options.update(overrides)
        url = options.pop("url", receiver_server.url)
        path = options.pop("outbox_path", outbox_path)
        poster = EventPoster(url, SERVER, SECRET, path, **options)
        posters.append(poster)
        return poster

    try:
        yield make
    finally:
        for poster in posters:
            await poster.close(flush_timeout_s=0)
