import json
from collections.abc import AsyncIterator
from dataclasses import dataclass
from typing import Any

import pytest
from mcp import Client
from mcp.server.mcpserver import MCPServer
from mcp_types import CallToolResult, TextContent

from robot_mcp_kit.task_events.fake import FakeEventSink
from robot_mcp_kit.tasks import TaskTable
from robot_mcp_navigation.map import parse_map
from robot_mcp_navigation.motion.fake import FakeMotionBase
from robot_mcp_navigation.navigator import Navigator
from robot_mcp_navigation.tools import build_mcp_server

MAP = {
    "start": "dock",
    "locations": {"dock": {"x": 0, "y": 0}, "kitchen": {"x": 8, "y": 0}},
    "speed_mps": 2.0,
}


def text_of(result: CallToolResult) -> str:
    (content,) = result.content
    assert isinstance(content, TextContent)
    return content.text


def json_of(result: CallToolResult) -> dict[str, Any]:
    assert not result.is_error, text_of(result)
    value: dict[str, Any] = json.loads(text_of(result))
    return value


def error_of(result: CallToolResult) -> dict[str, Any]:
    assert result.is_error
    text = text_of(result)
    value: dict[str, Any] = json.loads(text[text.index("{") :])
    return value


@dataclass
class Rig:
    base: FakeMotionBase
    events: FakeEventSink
    server: MCPServer


@pytest.fixture
async def rig() -> AsyncIterator[Rig]:
    base = FakeMotionBase(speed_mps=2.0)
    events = FakeEventSink()
    navigator = Navigator(parse_map(MAP), base, events, TaskTable())
    yield Rig(base, events, build_mcp_server(navigator))
    await navigator.close()


async def test_the_server_offers_the_navigation_and_task_tools(
    rig: Rig,
) -> None:
    async with Client(rig.server) as mcp_client:
        tools = {tool.name: tool for tool in (await mcp_client.list_tools()).tools}

        assert set(tools) == {
            "navigate_to",
            "stop_navigation",
            "get_pose",
            "list_locations",
            "get_task",
            "cancel_task",
            "list_tasks",
            "get_map",
            "get_plan",
        }
        assert "eta_below" in json.dumps(tools["navigate_to"].input_schema)
        assert "NAVIGATION_BUSY" in (tools["navigate_to"].description or "")


async def test_navigate_to_answers_with_task_info_json_the_brain_recognises(
    rig: Rig,
) -> None:
    async with Client(rig.server) as mcp_client:
        info = json_of(
            await mcp_client.call_tool(
                "navigate_to",
                {"location": "kitchen", "triggers": [{"type": "eta_below", "seconds": 2}]},
            )
        )

        assert info["state"] == "running"
        assert info["task_id"].startswith("nav-")
        assert info["est_duration_s"] == 4.0
        assert info["triggers"] == [{"type": "eta_below", "seconds": 2.0}]
        running = json_of(await mcp_client.call_tool("list_tasks", {"states": ["running"]}))
        assert [t["task_id"] for t in running["tasks"]] == [info["task_id"]]


async def test_domain_errors_come_back_as_readable_tool_errors(
    rig: Rig,
) -> None:
    async with Client(rig.server) as mcp_client:
        unknown = error_of(await mcp_client.call_tool("navigate_to", {"location": "attic"}))
        missing = error_of(await mcp_client.call_tool("get_task", {"task_id": "nav-x"}))
        cancel_missing = error_of(await mcp_client.call_tool("cancel_task", {"task_id": "nav-x"}))

        assert unknown["error"] == "UNKNOWN_LOCATION"
        assert "kitchen" in unknown["detail"]
        assert missing["error"] == "UNKNOWN_TASK"
        assert cancel_missing["error"] == "UNKNOWN_TASK"


async def test_an_unsupported_trigger_is_rejected_before_anything_moves(
    rig: Rig,
) -> None:
    async with Client(rig.server) as mcp_client:
        result = await mcp_client.call_tool(
            "navigate_to", {"location": "kitchen", "triggers": [{"type": "arrived_soon"}]}
        )

        assert result.is_error
        assert rig.base.goals == []


async def test_stop_navigation_returns_the_cancelled_task_and_pose(
    rig: Rig,
) -> None:
    async with Client(rig.server) as mcp_client:
        info = json_of(await mcp_client.call_tool("navigate_to", {"location": "kitchen"}))

        stopped = json_of(await mcp_client.call_tool("stop_navigation", {}))

        assert stopped["stopped"] is True
        assert stopped["cancelled_task"]["task_id"] == info["task_id"]
        assert stopped["cancelled_task"]["state"] == "cancelled"
        assert stopped["pose"]["moving"] is False
        assert rig.events.types(info["task_id"])[-1] == "task_failed"
        again = json_of(await mcp_client.call_tool("cancel_task", {"task_id": info["task_id"]}))
        assert again["state"] == "cancelled"
        assert (
            json_of(await mcp_client.call_tool("get_task", {"task_id": info["task_id"]}))["state"]
            == "cancelled"
        )


async def test_pose_and_locations_are_readable(
    rig: Rig,
) -> None:
    async with Client(rig.server) as mcp_client:
        pose = json_of(await mcp_client.call_tool("get_pose", {}))
        locations = json_of(await mcp_client.call_tool("list_locations", {}))

        assert pose["at_location"] == "dock"
        assert [loc["name"] for loc in locations["locations"]] == ["dock", "kitchen"]
        assert locations["locations"][1]["est_duration_s"] == 4.0
