"""The brain's notes for the episodic memory: sent after the event, never holding it up."""

from __future__ import annotations

import asyncio

from robot_voice_chat.services.emitter.base import EventEmitter
from robot_voice_chat.services.emitter.episodic import EpisodicNoteEmitter, note_for
from robot_voice_chat.services.tools.fake import FakeToolBackend
from robot_voice_chat.socket_events import (
    ChatMessage,
    MissionFinished,
    MissionStarted,
    SocketEvent,
    TeachingState,
)


class Recording(EventEmitter):
    def __init__(self) -> None:
        self.events: list[SocketEvent] = []

    async def emit(self, event: SocketEvent) -> None:
        self.events.append(event)


def test_notes_for_missions_and_conversation_lines() -> None:
    started = MissionStarted(mission_id="m-1", instruction="bring the mug")
    assert note_for(started) == {
        "kind": "mission_started", "text": "bring the mug", "mission_id": "m-1",
    }  # fmt: skip
    finished = MissionFinished(mission_id="m-1", outcome="succeeded", summary="Mug delivered")
    assert note_for(finished) == {
        "kind": "mission_finished", "text": "succeeded: Mug delivered", "mission_id": "m-1",
    }  # fmt: skip
    assert note_for(ChatMessage(turn_id="t", role="user", text="hi")) == {
        "kind": "user", "text": "hi",
    }  # fmt: skip
    assert note_for(ChatMessage(turn_id="t", role="assistant", text="Hello!"))["kind"] == "robot"  # type: ignore[index]
    assert note_for(ChatMessage(turn_id="t", role="user", text="  ")) is None
    assert note_for(TeachingState(armed=True)) is None


async def test_a_slow_episodic_server_never_holds_up_the_event() -> None:
    release = asyncio.Event()
    tools = FakeToolBackend()

    async def slow(_: dict[str, object]) -> str:
        await release.wait()
        return "{}"

    tools.add("episodic.record_note", slow)
    inner = Recording()
    emitter = EpisodicNoteEmitter(inner, tools)
    started = MissionStarted(mission_id="m-1", instruction="bring the mug")

    async with asyncio.timeout(1.0):  # returns at once although the note is still in flight
        await emitter.emit(started)
    assert inner.events == [started]
    release.set()
    await emitter.drain()
    assert tools.called("episodic.record_note") == [
        {"kind": "mission_started", "text": "bring the mug", "mission_id": "m-1"}
    ]


async def test_nothing_is_sent_while_episodic_is_not_connected_and_failures_are_absorbed() -> None:
    tools = FakeToolBackend()
    tools.add("episodic.record_note", lambda _: (_ for _ in ()).throw(ValueError("full")))
    inner = Recording()
    emitter = EpisodicNoteEmitter(inner, tools, max_pending=1)
    tools.states["episodic"] = "disconnected"
    await emitter.emit(ChatMessage(turn_id="t", role="user", text="hello"))
    assert tools.calls == []

    tools.states["episodic"] = "connected"
    await emitter.emit(ChatMessage(turn_id="t", role="user", text="one"))
    await emitter.emit(ChatMessage(turn_id="t", role="user", text="two"))  # over max_pending
    await emitter.drain()
    assert [args["text"] for _, args in tools.calls] == ["one"]  # the error was only logged
    assert len(inner.events) == 3
