"""Navigation's event receiver: every HMAC verified, the sender named in the header must be the
event's server, and a task's events read back in order without duplicates."""

from __future__ import annotations

import httpx

from robot_mcp_kit.models import EventType, TaskEvent
from robot_mcp_kit.signing import signed_headers
from robot_stack_testing.navigation.receiver import running_receiver
from robot_stack_testing.ports import free_tcp_port

SECRET = "navigation-receiver-secret"


def body_of(task_id: str, type_: EventType, seq: int, **payload: object) -> bytes:
    event = TaskEvent(
        task_id=task_id,
        server="navigation",
        tool="navigate_to",
        type=type_,
        seq=seq,
        payload=dict(payload),
    )
    return event.model_dump_json().encode()


def test_the_receiver_keeps_signed_events_of_their_own_server_only() -> None:
    with running_receiver(free_tcp_port(), SECRET) as receiver, httpx.Client() as client:
        progress = body_of("t1", "progress", 0, distance_remaining=3.0)
        done = body_of("t1", "task_done", 1)
        for body in (progress, progress, done, body_of("t2", "progress", 0)):
            sent = client.post(
                receiver.url, content=body, headers=signed_headers("navigation", SECRET, body)
            )
            assert sent.status_code == 200
        forged = client.post(
            receiver.url, content=done, headers=signed_headers("navigation", "wrong", done)
        )
        impostor = client.post(
            receiver.url, content=done, headers=signed_headers("manipulation", SECRET, done)
        )
    assert (forged.status_code, impostor.status_code) == (401, 401)
    assert receiver.rejected == ["bad_signature", "server_mismatch"]
    assert receiver.types("t1") == ["progress", "task_done"]
    terminal = receiver.terminal("t1")
    assert terminal is not None
    assert terminal.seq == 1
    assert receiver.terminal("t2") is None
    assert len(receiver.arrivals) == 3
