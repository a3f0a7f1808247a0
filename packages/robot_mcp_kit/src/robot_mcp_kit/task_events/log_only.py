"""LogOnlyEventSink: used when no RVC_EVENT_SECRET is set — events are logged, not posted."""

from __future__ import annotations

from typing import Any

import structlog

from robot_mcp_kit.models import EventType
from robot_mcp_kit.task_events.sink import EventSink

logger = structlog.get_logger(__name__)


class LogOnlyEventSink(EventSink):
    """The brain rejects unsigned events, so without a secret nothing is sent; the brain can
    still follow tasks by polling ``get_task`` / ``list_tasks``. ``brain_secret_env``: the
    brain's setting that holds this server's secret (named in the warning)."""

    def __init__(self, brain_secret_env: str | None = None) -> None:
        self.brain_secret_env = brain_secret_env or "event secret for this server"

    async def start(self) -> None:
        logger.warning(
            "event_secret_missing",
            detail="RVC_EVENT_SECRET is not set: task events are logged, not posted; "
            f"set it to the brain's {self.brain_secret_env} to enable push events",
        )

    async def emit(self, task_id: str, tool: str, type: EventType, payload: dict[str, Any]) -> None:
        logger.info("event_not_posted", task_id=task_id, tool=tool, type=type, payload=payload)
