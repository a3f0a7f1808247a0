"""Notes for the robot's episodic memory, fire-and-forget.

``EpisodicNoteEmitter`` wraps the real emitter: events are forwarded first, unchanged; a
mission start or finish and every complete conversation line then become an
``episodic.record_note`` call in a background task, so a slow or absent episodic server never
slows a mission or a reply. Nothing is sent while the server is not connected; at most
``max_pending`` notes are in flight (more are dropped and logged); failures are logged.
"""

from __future__ import annotations

import asyncio
from typing import Any

import structlog

from robot_voice_chat.services.emitter.base import EventEmitter
from robot_voice_chat.services.tools.base import ToolBackend
from robot_voice_chat.socket_events import ChatMessage, MissionFinished, MissionStarted, SocketEvent

logger = structlog.get_logger(__name__)

SERVER = "episodic"


def note_for(event: SocketEvent) -> dict[str, Any] | None:
    """The ``record_note`` arguments for ``event``, or None if it is not worth a note."""
    if isinstance(event, MissionStarted):
        return {
            "kind": "mission_started",
            "text": event.instruction,
            "mission_id": event.mission_id,
        }
    if isinstance(event, MissionFinished):
        text = f"{event.outcome}: {event.summary}" if event.summary else event.outcome
        return {"kind": "mission_finished", "text": text, "mission_id": event.mission_id}
    if isinstance(event, ChatMessage) and event.text.strip():
        return {"kind": "user" if event.role == "user" else "robot", "text": event.text}
    return None


class EpisodicNoteEmitter(EventEmitter):
    def __init__(
        self,
        inner: EventEmitter,
        tools: ToolBackend,
        *,
        timeout_s: float = 5.0,
        max_pending: int = 32,
    ) -> None:
        self.inner = inner
        self._tools = tools
        self._timeout_s = timeout_s
        self._max_pending = max_pending
        self._pending: set[asyncio.Task[None]] = set()

    async def emit(self, event: SocketEvent) -> None:
        await self.inner.emit(event)
        note = note_for(event)
        if note is None or self._tools.server_states().get(SERVER) != "connected":
            return
        if len(self._pending) >= self._max_pending:
            logger.warning("episodic_note_dropped", kind=note["kind"], pending=len(self._pending))
            return
        task = asyncio.create_task(self._record(note))
        self._pending.add(task)
        task.add_done_callback(self._pending.discard)

    async def _record(self, note: dict[str, Any]) -> None:
        outcome = await self._tools.call_tool(
            f"{SERVER}.record_note", note, timeout_s=self._timeout_s
        )
        if outcome.is_error:
            logger.warning("episodic_note_failed", kind=note["kind"], detail=outcome.text[:200])

    async def drain(self) -> None:
        """Wait for the notes in flight (tests, shutdown)."""
        if self._pending:
            await asyncio.gather(*self._pending, return_exceptions=True)
