"""The conversation as the UI showed it, so the last turns survive a page reload.

``HistoryRecordingEmitter`` wraps the real emitter: every complete conversation line
(``chat_message``, ``chat_error``, ``mission_finished``) is kept in a bounded
:class:`ChatHistory` and forwarded unchanged. Streamed deltas are not kept (their
``chat_message`` carries the whole reply).
"""

from __future__ import annotations

import time
from collections import deque
from typing import Any

from robot_voice_chat.services.emitter.base import EventEmitter
from robot_voice_chat.socket_events import ChatError, ChatMessage, MissionFinished, SocketEvent

RECORDED: tuple[type[SocketEvent], ...] = (ChatMessage, ChatError, MissionFinished)


class ChatHistory:
    """The last ``size`` conversation lines, oldest first: ``{event, ts, **payload}``."""

    def __init__(self, size: int = 50) -> None:
        self._lines: deque[dict[str, Any]] = deque(maxlen=size)

    def add(self, event: SocketEvent) -> None:
        self._lines.append({"event": event.EVENT, "ts": time.time(), **event.model_dump()})

    def lines(self, limit: int | None = None) -> list[dict[str, Any]]:
        lines = list(self._lines)
        return lines[-limit:] if limit else lines


class HistoryRecordingEmitter(EventEmitter):
    def __init__(self, inner: EventEmitter, history: ChatHistory) -> None:
        self.inner = inner
        self.history = history

    async def emit(self, event: SocketEvent) -> None:
        if isinstance(event, RECORDED):
            self.history.add(event)
        await self.inner.emit(event)
