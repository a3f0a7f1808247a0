"""The event port: where watch_events go. ``PosterEventSink`` posts HMAC-signed TaskEvents
through ``robot_mcp_kit.EventPoster``; ``LoggingEventSink`` is the no-brain fallback (events
are logged, not posted); ``RecordingEventSink`` is the test fake."""

from __future__ import annotations

import abc
from pathlib import Path
from typing import Any

import structlog

from robot_mcp_kit.models import EventType
from robot_mcp_kit.poster import EventPoster

logger = structlog.get_logger(__name__)


class EventSink(abc.ABC):
    async def start(self) -> None:  # noqa: B027 - optional hook
        """Open resources (outbox, HTTP client)."""

    async def close(self) -> None:  # noqa: B027 - optional hook
        """Flush and release resources."""

    @abc.abstractmethod
    async def emit(self, task_id: str, tool: str, type: EventType, payload: dict[str, Any]) -> None:
        """Deliver one task event (durably queued when this returns)."""

    def health(self) -> dict[str, Any]:
        """Whether events reach the brain (``status``) and the delivery counters."""
        return {"status": "ok"}


class PosterEventSink(EventSink):
    def __init__(self, url: str, secret: str, outbox_path: Path, server: str) -> None:
        outbox_path.parent.mkdir(parents=True, exist_ok=True)
        self._poster = EventPoster(url, server, secret, outbox_path)

    async def start(self) -> None:
        await self._poster.start()

    async def close(self) -> None:
        await self._poster.close()

    def health(self) -> dict[str, Any]:
        return self._poster.health()

    async def emit(self, task_id: str, tool: str, type: EventType, payload: dict[str, Any]) -> None:
        event = await self._poster.emit(task_id, tool, type, payload)
        logger.info("watch_event_queued", task_id=task_id, event_id=event.event_id, seq=event.seq)


class LoggingEventSink(EventSink):
    """Used when RVC_EVENTS_URL is not set: watchers still run and are visible via the task
    tools, but nothing is pushed to a brain."""

    def health(self) -> dict[str, Any]:
        return {"status": "not_posting", "reason": "RVC_EVENTS_URL is not set"}

    async def emit(self, task_id: str, tool: str, type: EventType, payload: dict[str, Any]) -> None:
        logger.warning("watch_event_not_posted", task_id=task_id, reason="RVC_EVENTS_URL unset")


class RecordingEventSink(EventSink):
    """Test fake: records every emitted event."""

    def __init__(self) -> None:
        self.events: list[tuple[str, str, str, dict[str, Any]]] = []

    async def emit(self, task_id: str, tool: str, type: EventType, payload: dict[str, Any]) -> None:
        self.events.append((task_id, tool, type, payload))
