"""Emits typed events on a python-socketio AsyncServer."""

from __future__ import annotations

from typing import Any

import structlog

from robot_voice_chat.services.emitter.base import EventEmitter
from robot_voice_chat.socket_events import SocketEvent

logger = structlog.get_logger(__name__)


class SocketIOEventEmitter(EventEmitter):
    def __init__(self, sio: Any) -> None:
        self._sio = sio

    async def emit(self, event: SocketEvent) -> None:
        await self._sio.emit(event.EVENT, event.model_dump(mode="json"))
