"""PosterEventSink: signed POSTs to the brain through robot_mcp_kit's EventPoster."""

from __future__ import annotations

from typing import Any

from robot_mcp_kit.models import EventType
from robot_mcp_kit.poster import EventPoster
from robot_mcp_manipulation.events.base import EventSink


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
