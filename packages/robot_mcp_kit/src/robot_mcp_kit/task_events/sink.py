"""EventSink: where a server's task events go (the brain, a log, or a test)."""

from __future__ import annotations

import abc
from typing import Any

from robot_mcp_kit.models import EventType


class EventSink(abc.ABC):
    """Accepts task events in order; durable adapters persist before ``emit`` returns."""

    async def start(self) -> None:  # noqa: B027 - optional hook, most sinks need nothing
        """Open resources (called once, inside the server's event loop)."""

    @abc.abstractmethod
    async def emit(self, task_id: str, tool: str, type: EventType, payload: dict[str, Any]) -> None:
        """Record or send one event; events of one task are emitted in order."""

    async def close(self) -> None:  # noqa: B027 - optional hook
        """Flush and release resources."""
