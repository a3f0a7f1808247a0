"""FakeEventSink: records every event in order, for tests."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from robot_mcp_kit.models import EventType
from robot_mcp_kit.task_events.sink import EventSink


@dataclass(frozen=True)
class RecordedEvent:
    task_id: str
    tool: str
    type: EventType
    payload: dict[str, Any] = field(default_factory=dict)


class FakeEventSink(EventSink):
    def __init__(self) -> None:
        self.events: list[RecordedEvent] = []
        self.started = False
        self.closed = False

    async def start(self) -> None:
        self.started = True

    async def emit(self, task_id: str, tool: str, type: EventType, payload: dict[str, Any]) -> None:
        self.events.append(RecordedEvent(task_id, tool, type, dict(payload)))

    async def close(self) -> None:
        self.closed = True

    def types(self, task_id: str) -> list[str]:
        return [e.type for e in self.events if e.task_id == task_id]
