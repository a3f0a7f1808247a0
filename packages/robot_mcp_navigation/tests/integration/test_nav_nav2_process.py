"""The navigation server with NAV_MOTION=nav2 as a real process, against a real rclpy
NavigateToPose action server in another process (robot_stack_testing.navigation.nav2_server),
over ROS on loopback; events are posted signed to a local receiver."""

from __future__ import annotations

import asyncio
import json
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
    async_wait_until,
    free_tcp_port,
    fresh_token,
    mcp_transport,
    wait_for_tcp_port,
    wait_until,
)
from robot_stack_testing.navigation.receiver import EventReceiver, running_receiver

pytestmark = [pytest.mark.ros, pytest.mark.slow]

TOKEN = fresh_token()  # the server's MCP_AUTH_TOKEN
SECRET = "nav2-integration-secret"
DOOR = "17,3,208,The mailroom door is closed."  # the office map's mailroom
CLOSED_DOOR_MAP = Path(__file__).parents[1] / "maps" / "office_closed_door.yaml"


@pytest.fixture
def receiver() -> Iterator[EventReceiver]:
    with running_receiver(free_tcp_port(), SECRET) as recv:
        yield recv


def start_nav2(launcher: ProcessLauncher, *args: str) -> LaunchedProcess:
    process = launcher.start(
        "fake-nav2", [sys.executable, "-m", "robot_stack_testing.navigation.nav2_server", *args]
    )
    wait_until(lambda: "fake_nav2_ready" in process.log(), 30, "the fake Nav2 to start")
    return process


def start_navigation(
    launcher: ProcessLauncher, receiver: EventReceiver, tmp_path: Path, **env: str
) -> int:
    port = free_tcp_port()
    process = launcher.start(
        "navigation",
        [sys.executable, "-m", "robot_mcp_navigation"],
        env={
            "NAV_MOTION": "nav2",
            "NAV_SUPERVISION": "off",  # no brain here to hold a lease
            "MCP_TRANSPORT": "streamable-http",
            "MCP_AUTH_TOKEN": TOKEN,
            "MCP_PORT": str(port),
            "RVC_EVENTS_URL": receiver.url,
            "RVC_EVENT_SECRET": SECRET,
            "NAV_OUTBOX": str(tmp_path / "outbox.sqlite3"),
            "NAV_PROGRESS_INTERVAL_S": "0.3",
            "NAV2_SERVER_TIMEOUT_S": "10",
            **env,
        },
    )
    try:
        wait_for_tcp_port(port, 30)
    except TimeoutError:
        raise AssertionError(f"navigation server did not start:\n{process.log()}") from None
    return port


def answer(result: CallToolResult) -> dict[str, Any]:
    (content,) = result.content
    assert isinstance(content, TextContent)
    value: dict[str, Any] = json.loads(content.text)
    if result.is_error:
        return {"tool_error": value}
    return value


async def test_arrival_posts_progress_triggers_and_task_done_in_order(
    launcher: ProcessLauncher, receiver: EventReceiver, tmp_path: Path
) -> None:
    start_nav2(launcher, "--speed", "3")
    port = start_navigation(launcher, receiver, tmp_path)
    async with Client(mcp_transport(f"http://127.0.0.1:{port}/mcp", TOKEN)) as client:
        info = answer(
            await client.call_tool(
                "navigate_to",
                {"location": "kitchen", "triggers": [{"type": "distance_below", "meters": 3}]},
            )
        )
        assert info["state"] == "running", info
        task_id = info["task_id"]
        await async_wait_until(lambda: receiver.terminal(task_id), 60, "task_done")
        final = answer(await client.call_tool("get_task", {"task_id": task_id}))
        pose = answer(await client.call_tool("get_pose", {}))

    types = receiver.types(task_id)
    assert types[0] == "progress"
    assert types[-1] == "task_done"
    assert types.count("trigger_fired") == 1
    assert types.count("task_done") == 1
    fired = next(e for e in receiver.unique(task_id) if e.type == "trigger_fired")
    assert fired.payload["distance_remaining_m"] < 3
    seqs = [e.seq for e in receiver.unique(task_id)]
    assert seqs == sorted(seqs)
    assert final["state"] == "succeeded"
    assert pose["at_location"] == "kitchen"
    assert receiver.rejected == []


async def test_abort_is_task_failed_with_the_mapped_code_and_the_maps_detour(
    launcher: ProcessLauncher, receiver: EventReceiver, tmp_path: Path
) -> None:
    start_nav2(launcher, "--speed", "6", "--abort", DOOR)
    # a map whose failures: entry names the detour (the shipped office map has none)
    port = start_navigation(launcher, receiver, tmp_path, NAV_MAP=str(CLOSED_DOOR_MAP))
    async with Client(mcp_transport(f"http://127.0.0.1:{port}/mcp", TOKEN)) as client:
        info = answer(await client.call_tool("navigate_to", {"location": "mailroom"}))
        await async_wait_until(lambda: receiver.terminal(info["task_id"]), 60, "task_failed")
        task = answer(await client.call_tool("get_task", {"task_id": info["task_id"]}))

    terminal = receiver.terminal(info["task_id"])
    assert terminal is not None
    assert terminal.type == "task_failed"
    assert terminal.payload["error_code"] == "NO_PATH"
    assert terminal.payload["recoverable"] is True
    assert "Nav2 error 208: The mailroom door is closed." in terminal.payload["message"]
    assert any("corridor_b" in s for s in terminal.payload["suggestions"])
    assert task["state"] == "failed"
    assert task["error"]["error_code"] == "NO_PATH"


async def test_stop_mid_drive_cancels_the_goal_at_the_server_with_one_terminal_event(
    launcher: ProcessLauncher, receiver: EventReceiver, tmp_path: Path
) -> None:
    nav2 = start_nav2(launcher, "--speed", "0.5")
    port = start_navigation(launcher, receiver, tmp_path)
    async with Client(mcp_transport(f"http://127.0.0.1:{port}/mcp", TOKEN)) as client:
        info = answer(await client.call_tool("navigate_to", {"location": "meeting_room"}))
        task_id = info["task_id"]
        await async_wait_until(lambda: "progress" in receiver.types(task_id), 30, "progress")
        busy = answer(await client.call_tool("navigate_to", {"location": "kitchen"}))
        stopped = answer(await client.call_tool("stop_navigation", {}))
        # stop_navigation returns once Nav2 reported the goal CANCELED
        assert "goal_canceled" in nav2.log()
        await async_wait_until(lambda: receiver.terminal(task_id), 30, "the terminal event")
        later = answer(await client.call_tool("navigate_to", {"location": "reception"}))
        await async_wait_until(lambda: "progress" in receiver.types(later["task_id"]), 30, "p")
        await client.call_tool("stop_navigation", {})

    assert busy["tool_error"]["error"] == "NAVIGATION_BUSY"
    assert stopped["cancelled_task"]["state"] == "cancelled"
    events = receiver.unique(task_id)
    assert [e.type for e in events].count("task_failed") == 1
    assert events[-1].type == "task_failed"
    assert events[-1].payload["error_code"] == "CANCELLED"
    assert nav2.log().count("goal_canceled") == 2


async def test_absent_action_server_is_a_clean_error_then_recovers_when_nav2_starts(
    launcher: ProcessLauncher, receiver: EventReceiver, tmp_path: Path
) -> None:
    port = start_navigation(launcher, receiver, tmp_path, NAV2_SERVER_TIMEOUT_S="1")
    async with Client(mcp_transport(f"http://127.0.0.1:{port}/mcp", TOKEN)) as client:
        loop = asyncio.get_running_loop()
        started = loop.time()
        refused = answer(await client.call_tool("navigate_to", {"location": "kitchen"}))
        waited_s = loop.time() - started
        tasks = answer(await client.call_tool("list_tasks", {}))
        start_nav2(launcher, "--speed", "4")  # Nav2 comes up after the navigation server
        outcome: dict[str, Any] = {}

        async def accepted() -> bool:
            outcome.update(answer(await client.call_tool("navigate_to", {"location": "kitchen"})))
            return "task_id" in outcome

        await async_wait_until(accepted, 60, "a goal accepted once Nav2 is up", 0.2)
        await async_wait_until(lambda: receiver.terminal(outcome["task_id"]), 60, "task_done")

    assert refused["tool_error"]["error"] == "BASE_UNAVAILABLE"
    assert "/navigate_to_pose" in refused["tool_error"]["detail"]
    assert waited_s >= 1.0  # it waited its NAV2_SERVER_TIMEOUT_S for Nav2, then gave up
    assert tasks["tasks"] == []
    terminal = receiver.terminal(outcome["task_id"])
    assert terminal is not None
    assert terminal.type == "task_done"


async def test_pose_comes_from_amcl_pose(
    launcher: ProcessLauncher, receiver: EventReceiver, tmp_path: Path
) -> None:
    start_nav2(launcher, "--start", "4,1.5")  # standing at reception
    port = start_navigation(launcher, receiver, tmp_path)
    async with Client(mcp_transport(f"http://127.0.0.1:{port}/mcp", TOKEN)) as client:
        pose: dict[str, Any] = {}

        async def at_reception() -> bool:
            pose.update(answer(await client.call_tool("get_pose", {})))
            return pose["at_location"] == "reception"

        await async_wait_until(at_reception, 30, "the pose from /amcl_pose", 0.1)
    assert (pose["x"], pose["y"], pose["moving"]) == (4.0, 1.5, False)
