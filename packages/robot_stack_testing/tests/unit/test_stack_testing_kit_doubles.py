"""The kit's doubles: the signature-checking event receiver (as a poster sees the brain), its
ordering check, and the reading of a tool's answer and an approved call's ``_meta``."""

from __future__ import annotations

import httpx
import pytest
from mcp import Client
from mcp.server.mcpserver import MCPServer

from robot_mcp_kit.approvals import ApprovalVerifier
from robot_mcp_kit.caller import APPROVAL_META_KEY
from robot_mcp_kit.mcp_runtime import install_json_tool_errors, tool_error
from robot_mcp_kit.models import TaskEvent
from robot_mcp_kit.signing import signed_headers
from robot_stack_testing.kit.receiver import (
    Delivery,
    ReceiverServer,
    RecordingReceiver,
    Reply,
    order_violations,
)
from robot_stack_testing.kit.tool_calls import approved, tool_answer
from robot_stack_testing.ports import free_tcp_port

SECRET = "kit-doubles-event-secret"
APPROVAL_SECRET = "kit-doubles-approval-secret-of-32-bytes-or-more"


def event(task_id: str = "t1", seq: int = 0) -> TaskEvent:
    return TaskEvent(
        task_id=task_id, server="navigation", tool="navigate_to", type="progress", seq=seq
    )


async def post(
    client: httpx.AsyncClient, url: str, body: bytes, secret: str = SECRET
) -> httpx.Response:
    return await client.post(url, content=body, headers=signed_headers("navigation", secret, body))


async def test_the_receiver_records_signed_events_and_refuses_the_rest() -> None:
    receiver = RecordingReceiver({"navigation": SECRET})
    receiver.responder = lambda e: Reply(503, {"Retry-After": "1"}) if e.seq == 1 else None
    async with ReceiverServer(receiver, free_tcp_port()) as server, httpx.AsyncClient() as client:
        assert server.running
        first, second = event(seq=0), event(seq=1)
        assert (await post(client, server.url, first.model_dump_json().encode())).status_code == 200
        busy = await post(client, server.url, second.model_dump_json().encode())
        assert (busy.status_code, busy.headers["retry-after"]) == (503, "1")
        forged = await post(client, server.url, first.model_dump_json().encode(), "wrong")
        assert forged.status_code == 401
        assert (await post(client, server.url, b'{"not": "an event"}')).status_code == 400
        stray = await client.get(server.url.replace("/api/agent/events", "/elsewhere"))
        assert stray.status_code == 404
    assert not server.running
    assert receiver.attempts == 4
    assert [d.status for d in receiver.deliveries] == [200, 503]
    assert receiver.accepted_ids() == {first.event_id}
    assert receiver.rejections == ["bad_signature", "invalid_event"]


async def test_a_receiver_server_starts_again_on_the_same_port() -> None:
    receiver = RecordingReceiver({"navigation": SECRET})
    server = ReceiverServer(receiver, free_tcp_port())
    await server.start()
    await server.start()  # already running: nothing happens
    await server.stop()
    await server.stop()
    async with server, httpx.AsyncClient() as client:
        body = event().model_dump_json().encode()
        assert (await post(client, server.url, body)).status_code == 200
    assert len(receiver.accepted()) == 1


def delivered(e: TaskEvent, status: int = 200, body: bytes | None = None) -> Delivery:
    return Delivery(e, body if body is not None else e.model_dump_json().encode(), 0.0, status)


def test_order_violations_finds_a_seq_going_back_changed_bytes_and_a_shared_seq() -> None:
    a0, a1 = event(seq=0), event(seq=1)
    assert order_violations([delivered(a0), delivered(a1), delivered(a1)]) == []
    assert order_violations([delivered(a1), delivered(a0, status=503)]) == []
    other = event(seq=1)
    problems = order_violations(
        [delivered(a1), delivered(a0), delivered(a1, body=b"{}"), delivered(other)]
    )
    assert problems == [
        "task t1: seq 0 delivered after 1",
        f"event {a1.event_id} was delivered with different bytes",
        "task t1: seq 1 used by two event ids",
    ]


def test_approved_signs_exactly_this_call_under_a_fresh_id() -> None:
    verifier = ApprovalVerifier("memory", APPROVAL_SECRET)
    meta = approved(APPROVAL_SECRET, "memory", "forget", {"key": "mug"}, by="ana")
    again = approved(APPROVAL_SECRET, "memory", "forget", {"key": "mug"})
    assert meta[APPROVAL_META_KEY]["approval_id"] != again[APPROVAL_META_KEY]["approval_id"]
    assert verifier.verify(meta[APPROVAL_META_KEY], "forget", {"key": "mug"}).by == "ana"
    with pytest.raises(Exception, match="approval refused"):
        verifier.verify(again[APPROVAL_META_KEY], "forget", {"key": "cup"})


async def test_tool_answer_reads_a_structured_answer_and_a_tool_error() -> None:
    server = MCPServer("kit-doubles")
    install_json_tool_errors(server)

    @server.tool()
    async def open_door(door: str) -> dict[str, str]:
        """Opens a door unless it is locked."""
        if door == "mailroom":
            raise tool_error("DOOR_LOCKED", f"the {door} door is locked")
        return {"opened": door}

    async with Client(server) as client:
        assert await tool_answer(client, "open_door", {"door": "lab"}) == {"opened": "lab"}
        refused = await tool_answer(client, "open_door", {"door": "mailroom"}, meta={"x": 1})
    assert refused["_error"]["error"] == "DOOR_LOCKED"
