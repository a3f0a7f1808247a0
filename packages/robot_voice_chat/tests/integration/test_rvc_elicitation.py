"""The brain declares MCP elicitation and routes a server's question into the approval card:
the real navigation server (NAV_CONFIRM_MOTION=elicit, over stdio) asks before driving."""

from __future__ import annotations

import asyncio
import json
import sys
import time
from collections.abc import AsyncIterator
from pathlib import Path

import pytest

from robot_stack_testing import async_wait_until
from robot_voice_chat.agent.trace import TraceRecorder
from robot_voice_chat.control.approvals import ApprovalBroker
from robot_voice_chat.control.elicitation import approval_elicitation, yes_no_field
from robot_voice_chat.services.emitter.base import FakeEventEmitter
from robot_voice_chat.services.tools.mcp import McpToolBackend
from robot_voice_chat.settings import McpServerConfig
from robot_voice_chat.socket_events import ApprovalRequested


@pytest.fixture
async def asking_navigation(tmp_path: Path) -> AsyncIterator[tuple[McpToolBackend, ApprovalBroker]]:
    server = McpServerConfig(
        name="navigation",
        transport="stdio",
        command=sys.executable,
        args=["-m", "robot_mcp_navigation"],
        env={
            "NAV_CONFIRM_MOTION": "elicit",
            "NAV_SUPERVISION": "off",  # a host asking its person, no supervising brain
            "MCP_TRANSPORT": "stdio",
            "NAV_OUTBOX": str(tmp_path / "outbox.sqlite3"),
            "NAV_TIME_SCALE": "20",
        },
        motion=True,
        safety_stop_tool="stop_navigation",
    )
    tools = McpToolBackend([server], connect_timeout_s=60, reconnect_interval_s=0.5)
    broker = ApprovalBroker(
        emitter=FakeEventEmitter(),
        trace=TraceRecorder(tmp_path / "missions"),
        audit_path=tmp_path / "approvals.jsonl",
        timeout_s=30,
    )
    tools.set_elicitation_handler(approval_elicitation(broker, lambda: None))
    await tools.start()
    try:
        await async_wait_until(
            lambda: tools.server_states()["navigation"] == "connected", 60, "navigation connected"
        )
        yield tools, broker
    finally:
        await tools.aclose()


async def test_the_servers_question_becomes_an_approval_and_yes_drives(
    asking_navigation: tuple[McpToolBackend, ApprovalBroker],
) -> None:
    tools, broker = asking_navigation
    call = asyncio.create_task(tools.call_tool("navigation.navigate_to", {"location": "kitchen"}))
    await async_wait_until(lambda: broker.pending(), 30, "the question on the approval card")
    (pending,) = broker.pending()
    event = pending.event()
    assert isinstance(event, ApprovalRequested)
    assert event.tool == "navigation.elicitation"
    assert "kitchen" in event.arguments["question"]
    assert not call.done()  # nothing drives before the yes

    broker.resolve(pending.approval_id, "approve", "alice")
    outcome = await call
    assert not outcome.is_error, outcome.text
    assert json.loads(outcome.text)["state"] == "running"
    await tools.call_tool("navigation.stop_navigation", {})


async def test_a_denied_question_is_a_clean_refusal_and_the_robot_stays(
    asking_navigation: tuple[McpToolBackend, ApprovalBroker],
) -> None:
    tools, broker = asking_navigation
    call = asyncio.create_task(tools.call_tool("navigation.navigate_to", {"location": "kitchen"}))
    await async_wait_until(lambda: broker.pending(), 30, "the question on the approval card")
    broker.resolve(broker.pending()[0].approval_id, "deny", "bob")

    outcome = await call
    assert outcome.is_error
    assert "MOTION_NOT_CONFIRMED" in outcome.text
    pose = json.loads((await tools.call_tool("navigation.get_pose", {})).text)
    assert pose["moving"] is False


async def test_a_call_out_too_long_is_marked_cut_off_and_one_never_sent_is_not(
    asking_navigation: tuple[McpToolBackend, ApprovalBroker],
) -> None:
    """A motion call that went out and did not answer may have started something (the
    dispatcher tells the person it lost contact); one never sent did not."""
    tools, broker = asking_navigation
    out = await tools.call_tool("navigation.navigate_to", {"location": "kitchen"}, 0.5)
    assert out.is_error
    assert out.cut_off
    assert "timed out after" in out.text
    never_sent = await tools.call_tool("arm.pick", {})
    assert never_sent.is_error
    assert not never_sent.cut_off
    await async_wait_until(lambda: broker.pending(), 30, "the question still asked")
    broker.resolve(broker.pending()[0].approval_id, "deny", "bob")  # nothing drives


def test_only_a_single_yes_no_field_is_answerable() -> None:
    assert yes_no_field({"properties": {"confirm": {"type": "boolean"}}}) == "confirm"
    assert yes_no_field({"properties": {"name": {"type": "string"}}}) is None
    two = {"properties": {"a": {"type": "boolean"}, "b": {"type": "boolean"}}}
    assert yes_no_field(two) is None
    assert yes_no_field({}) is None


async def test_the_question_expires_before_the_tool_call_would_time_out(tmp_path: Path) -> None:
    broker = ApprovalBroker(
        emitter=FakeEventEmitter(),
        trace=TraceRecorder(tmp_path / "missions"),
        audit_path=tmp_path / "approvals.jsonl",
        timeout_s=60,
    )
    handler = approval_elicitation(broker, lambda: None, call_timeout_s=2.0)
    schema = {"properties": {"confirm": {"type": "boolean"}}}
    asked = asyncio.create_task(handler("navigation", "Drive to the kitchen?", schema))
    await async_wait_until(lambda: broker.pending(), 5, "the question")
    assert broker.pending()[0].expires_at - time.time() <= 1.8 + 0.1

    assert await asked == ("decline", None)  # nobody answered: declined, never a yes
