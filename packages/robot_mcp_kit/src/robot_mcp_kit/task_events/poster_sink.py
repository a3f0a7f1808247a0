"""PosterEventSink: signed POSTs to the brain through the kit's EventPoster."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from pydantic import SecretStr

from robot_mcp_kit.models import EventType
from robot_mcp_kit.poster import EventPoster
from robot_mcp_kit.task_events.log_only import LogOnlyEventSink
from robot_mcp_kit.task_events.sink import EventSink


class PosterEventSink(EventSink):
    """Durable (outbox) and ordered per task; delivery retries happen inside the poster."""

    def __init__(self, poster: EventPoster, flush_timeout_s: float = 5.0) -> None:
        self._poster = poster
        self._flush_timeout_s = flush_timeout_s

    async def start(self) -> None:
        await self._poster.start()

    async def emit(self, task_id: str, tool: str, type: EventType, payload: dict[str, Any]) -> None:
        await self._poster.emit(task_id, tool, type, payload)

    async def close(self) -> None:
        await self._poster.close(flush_timeout_s=self._flush_timeout_s)


def build_event_sink(
    server: str,
    events_url: str,
    secret: SecretStr | None,
    outbox_path: Path,
    brain_secret_env: str,
) -> EventSink:
    """Signed posts to the brain when a secret is configured, else log-only (documented)."""
    if secret is None:
        return LogOnlyEventSink(brain_secret_env)
    outbox_path.parent.mkdir(parents=True, exist_ok=True)
    return PosterEventSink(EventPoster(events_url, server, secret.get_secret_value(), outbox_path))
