"""The event-emitter port: the agent and pipeline talk to the UI only through this."""

from __future__ import annotations

import abc

from robot_voice_chat.robot_words import sentences_of, witness
from robot_voice_chat.socket_events import SocketEvent


class EventEmitter(abc.ABC):
    @abc.abstractmethod
    async def emit(self, event: SocketEvent) -> None:
        """Broadcast ``event`` to every connected UI; never raises for delivery problems."""


class FakeEventEmitter(EventEmitter):
    def __init__(self) -> None:
        self.events: list[SocketEvent] = []

    async def emit(self, event: SocketEvent) -> None:
        self.events.append(event)
        witness(sentences_of(event))

    def of(self, cls: type[SocketEvent]) -> list[SocketEvent]:
        return [e for e in self.events if isinstance(e, cls)]
