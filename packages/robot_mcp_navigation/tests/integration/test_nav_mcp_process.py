"""The navigation server as a real process, driven over real MCP transports, posting signed
events to a local receiver that verifies every HMAC."""

from __future__ import annotations

import asyncio
import json
import math
import os
import signal
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from mcp import Client
from mcp_types import CallToolResult, TextContent

from robot_stack_testing import (
    LaunchedProcess,
    ProcessLauncher,
    assert_refuses_strangers,
    async_wait_until,
    free_tcp_port,
    fresh_token,
    mcp_transport,
    wait_for_tcp_port,
)
from robot_stack_testing.navigation.receiver import EventReceiver, running_receiver

TOKEN = fresh_token()  # the server's MCP_AUTH_TOKEN
SECRET = "integration-test-secret"


@pytest.fixture
def receiver(tcp_port: int) -> Iterator[EventReceiver]:
    with running_receiver(tcp_port, SECRET) as recv:
        yield recv


CLOSED_DOOR_MAP = Path(__file__).parents[1] / "maps" / "office_closed_door.yaml"
"""The office places with a scripted closed mailroom door (the in-process simulated base)."""


def start_navigation(
    launcher: ProcessLauncher,
    receiver: EventReceiver,
    port: int,
    tmp_path: Path,
    transport: str,
    **extra_env: str,
) -> LaunchedProcess:

    env = {
        "MCP_TRANSPORT": transport,
        "MCP_AUTH_TOKEN": TOKEN,
        "MCP_PORT": str(port),
        "RVC_EVENTS_URL": receiver.url,
        "RVC_EVENT_SECRET": SECRET,
        "NAV_OUTBOX": str(tmp_path / "outbox.sqlite3"),
        "NAV_POSE_PATH": str(tmp_path / "pose.json"),
        "NAV_TIME_SCALE": "40",
        "NAV_TICK_S": "0.02",
        "NAV_PROGRESS_INTERVAL_S": "1.0",
        "NAV_SUPERVISION": "off",  # no brain here to hold a lease: a dry run, unsupervised
        **extra_env,
    }
    process = launcher.start("navigation", [sys.executable, "-m", "robot_mcp_navigation"], env=env)
    try:
        wait_for_tcp_port(port, 20)
    except TimeoutError:
        raise AssertionError(f"navigation server did not start:\n{process.log()}") from None
    return process


def payload(result: CallToolResult) -> dict[str, Any]:
    (content,) = result.content
    assert isinstance(content, TextContent)
    assert not result.is_error, content.text
    value: dict[str, Any] = json.loads(content.text)
    return value


def assert_ordered(receiver: EventReceiver, task_id: str) -> None:
    seqs = [e.seq for e in receiver.unique(task_id)]
    assert seqs == sorted(seqs), f"events of {task_id} arrived out of order: {seqs}"
    assert len(set(seqs)) == len(seqs), f"seq reused in {task_id}: {seqs}"


async def test_navigation_over_streamable_http_posts_signed_ordered_events_and_fires_triggers(
    launcher: ProcessLauncher, receiver: EventReceiver, tmp_path: Path
) -> None:
    port = free_tcp_port()
    start_navigation(launcher, receiver, port, tmp_path, "streamable-http")
    # nobody without the server's credential gets in (issue 27)
    await asyncio.to_thread(assert_refuses_strangers, f"http://127.0.0.1:{port}/mcp", "navigation")

    async with Client(mcp_transport(f"http://127.0.0.1:{port}/mcp", TOKEN)) as client:
        info = payload(
            await client.call_tool(
                "navigate_to",
                {"location": "kitchen", "triggers": [{"type": "eta_below", "seconds": 5}]},
            )
        )
        assert info["state"] == "running"
        task_id = info["task_id"]
        await async_wait_until(lambda: receiver.terminal(task_id), 30, "task_done at receiver")
        final = payload(await client.call_tool("get_task", {"task_id": task_id}))
        pose = payload(await client.call_tool("get_pose", {}))

    events = receiver.unique(task_id)
    types = [e.type for e in events]
    assert types[0] == "progress"
    assert types[-1] == "task_done"
    assert types.count("trigger_fired") == 1
    fired = next(e for e in events if e.type == "trigger_fired")
    assert fired.payload["trigger"] == {"type": "eta_below", "seconds": 5.0}
    assert fired.payload["eta_s"] < 5
    assert all(e.server == "navigation" and e.tool == "navigate_to" for e in events)
    assert_ordered(receiver, task_id)
    assert receiver.rejected == []
    assert final["state"] == "succeeded"
    assert pose["at_location"] == "kitchen"


async def test_the_closed_mailroom_door_fails_the_task_with_suggestions_over_sse(
    launcher: ProcessLauncher, receiver: EventReceiver, tmp_path: Path
) -> None:
    port = free_tcp_port()
    start_navigation(launcher, receiver, port, tmp_path, "sse", NAV_MAP=str(CLOSED_DOOR_MAP))

    async with Client(mcp_transport(f"http://127.0.0.1:{port}/sse", TOKEN)) as client:
        first = payload(await client.call_tool("navigate_to", {"location": "mailroom"}))
        await async_wait_until(lambda: receiver.terminal(first["task_id"]), 30, "task_failed")
        failed = payload(await client.call_tool("get_task", {"task_id": first["task_id"]}))
        retry = payload(await client.call_tool("navigate_to", {"location": "mailroom"}))
        await async_wait_until(lambda: receiver.terminal(retry["task_id"]), 30, "task_done")

    terminal = receiver.terminal(first["task_id"])
    assert terminal is not None
    assert terminal.type == "task_failed"
    assert terminal.payload["error_code"] == "DOOR_CLOSED"
    assert terminal.payload["recoverable"] is True
    assert any("open" in s for s in terminal.payload["suggestions"])
    assert any("corridor_b" in s for s in terminal.payload["suggestions"])
    assert failed["state"] == "failed"
    retried = receiver.terminal(retry["task_id"])
    assert retried is not None
    assert retried.type == "task_done"
    assert_ordered(receiver, first["task_id"])
    assert_ordered(receiver, retry["task_id"])
    assert receiver.rejected == []


async def test_stop_navigation_mid_drive_cancels_the_task_and_ends_its_events(
    launcher: ProcessLauncher, receiver: EventReceiver, tmp_path: Path
) -> None:
    port = free_tcp_port()
    start_navigation(
        launcher,
        receiver,
        port,
        tmp_path,
        "streamable-http",
        NAV_TIME_SCALE="4",
        NAV_FAILURES="off",
    )

    async with Client(mcp_transport(f"http://127.0.0.1:{port}/mcp", TOKEN)) as client:
        info = payload(await client.call_tool("navigate_to", {"location": "meeting_room"}))
        task_id = info["task_id"]
        await async_wait_until(
            lambda: len([e for e in receiver.unique(task_id) if e.type == "progress"]) >= 2,
            30,
            "two progress events",
        )
        stopped = payload(await client.call_tool("stop_navigation", {}))
        await async_wait_until(lambda: receiver.terminal(task_id), 30, "the terminal event")
        pose_after_stop = payload(await client.call_tool("get_pose", {}))
        # A later navigation's completion proves the server kept running past the stop;
        # the stopped task must still have posted nothing after its terminal event.
        later = payload(await client.call_tool("navigate_to", {"location": "dock"}))
        await async_wait_until(lambda: receiver.terminal(later["task_id"]), 60, "later drive")
        listing = payload(await client.call_tool("list_tasks", {"states": ["cancelled"]}))

    assert stopped["cancelled_task"]["state"] == "cancelled"
    assert pose_after_stop["moving"] is False
    assert pose_after_stop["at_location"] is None
    events = receiver.unique(task_id)
    assert events[-1].type == "task_failed"
    assert events[-1].payload["error_code"] == "CANCELLED"
    assert events[-1].payload["state"] == "cancelled"
    assert events[-1].seq == max(e.seq for e in events)
    assert [e.type for e in events].count("task_failed") == 1
    assert_ordered(receiver, task_id)
    assert [t["task_id"] for t in listing["tasks"]] == [task_id]


async def test_a_navigation_server_killed_mid_drive_restarts_where_the_robot_was(
    launcher: ProcessLauncher, receiver: EventReceiver, tmp_path: Path
) -> None:
    """Issue 23 item 7: kill -9 mid-drive and a restart must not teleport the base to the
    dock; it reports the pose it had reached (kept in NAV_POSE_PATH)."""
    port = free_tcp_port()
    process = start_navigation(
        launcher, receiver, port, tmp_path, "streamable-http", NAV_TIME_SCALE="2"
    )
    async with Client(mcp_transport(f"http://127.0.0.1:{port}/mcp", TOKEN)) as client:
        dock = payload(await client.call_tool("get_pose", {}))
        assert dock["at_location"] == "dock"
        await client.call_tool("navigate_to", {"location": "kitchen"})

        async def under_way() -> bool:
            pose = payload(await client.call_tool("get_pose", {}))
            return bool(math.hypot(pose["x"] - dock["x"], pose["y"] - dock["y"]) > 1.0)

        await async_wait_until(under_way, 30, "the robot a metre from the dock", interval_s=0.1)
    os.kill(process.pid, signal.SIGKILL)
    process.popen.wait(timeout=10)

    start_navigation(launcher, receiver, port, tmp_path, "streamable-http")
    async with Client(mcp_transport(f"http://127.0.0.1:{port}/mcp", TOKEN)) as client:
        pose = payload(await client.call_tool("get_pose", {}))
    assert pose["at_location"] is None, pose  # neither the dock nor the kitchen
    assert math.hypot(pose["x"] - dock["x"], pose["y"] - dock["y"]) > 0.5, pose
    assert pose["moving"] is False
