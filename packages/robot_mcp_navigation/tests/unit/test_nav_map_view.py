"""get_map / get_plan: the robot's own map (/map, the global costmap) and the plan it follows
(/plan), read through the MapView port and served small for a display."""

from __future__ import annotations

import base64
import json
import time
from collections.abc import AsyncIterator
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np
import pytest
from mcp import Client
from mcp.server.mcpserver import MCPServer

from robot_mcp_kit.task_events.fake import FakeEventSink
from robot_mcp_kit.tasks import TaskTable
from robot_mcp_navigation.map import parse_map
from robot_mcp_navigation.mapview.base import GridSnapshot
from robot_mcp_navigation.mapview.fake import FakeMapView
from robot_mcp_navigation.mapview.render import MAX_PLAN_POINTS, floor_view, plan_points
from robot_mcp_navigation.motion.fake import FakeMotionBase
from robot_mcp_navigation.navigator import Navigator
from robot_mcp_navigation.tools import build_mcp_server
from robot_stack_testing import async_wait_until

MAP = {"start": "dock", "locations": {"dock": {"x": 0.5, "y": 0.5}, "hall": {"x": 1.5, "y": 0.5}}}


def grid(rows: list[list[int]], resolution: float = 0.5) -> GridSnapshot:
    """``rows`` top row first, as one reads them."""
    cells = np.asarray(rows[::-1], np.int8)
    height, width = cells.shape
    return GridSnapshot("map", resolution, (-1.0, -1.0), width, height, cells.tobytes(), 1.0)


def decode(png: str) -> np.ndarray:  # type: ignore[type-arg]
    pixels = cv2.imdecode(np.frombuffer(base64.b64decode(png), np.uint8), cv2.IMREAD_GRAYSCALE)
    return np.asarray(pixels > 127)


ROOM = [
    [-1, -1, -1, -1, -1, -1],
    [-1, 100, 100, 100, 100, -1],
    [-1, 100, 0, 0, 0, -1],
    [-1, 100, 0, 0, 0, -1],  # a doorway, two cells wide, on the right
    [-1, 100, 100, 100, 100, -1],
]


def test_the_floor_is_two_masks_the_known_bounds_and_nothing_blocked_without_a_costmap() -> None:
    view = floor_view(grid(ROOM), None)
    assert decode(view["walls_png"]).tolist() == [[v == 100 for v in row] for row in ROOM]
    assert decode(view["unknown_png"]).tolist() == [[v == -1 for v in row] for row in ROOM]
    assert view["bounds"] == {"x0": -0.5, "y0": -1.0, "x1": 1.5, "y1": 1.0}
    assert (view["resolution"], view["origin"], view["frame"]) == (
        0.5,
        {"x": -1.0, "y": -1.0},
        "map",
    )
    assert view["blocked"] == []


def test_cells_the_costmap_blocks_where_the_map_is_free_are_named_as_rectangles() -> None:
    costmap = [row[:] for row in ROOM]
    costmap[2][4] = costmap[3][4] = 100  # the doorway, seen closed
    costmap[2][2] = 99  # inflation is not an obstacle
    costmap[1][1] = 100  # a wall is no news
    view = floor_view(grid(ROOM), grid(costmap))
    assert view["blocked"] == [{"x0": 1.0, "y0": -0.5, "x1": 1.5, "y1": 0.5}]
    assert (
        floor_view(grid(ROOM), grid(costmap))["version"] != floor_view(grid(ROOM), None)["version"]
    )
    other = GridSnapshot("map", 0.25, (-1.0, -1.0), 6, 5, bytes(30), 1.0)
    assert floor_view(grid(ROOM), other)["blocked"] == []  # another grid: not compared


def test_a_long_plan_is_thinned_keeping_both_ends() -> None:
    from robot_mcp_navigation.mapview.base import PathSnapshot

    points = tuple((i * 0.01, 0.0) for i in range(1000))
    thinned = plan_points(PathSnapshot("map", points, 0.0))
    assert len(thinned) == MAX_PLAN_POINTS
    assert thinned[0] == [0.0, 0.0]
    assert thinned[-1] == [9.99, 0.0]


@dataclass
class Rig:
    base: FakeMotionBase
    view: FakeMapView
    navigator: Navigator
    server: MCPServer


@pytest.fixture
async def rig() -> AsyncIterator[Rig]:
    base, view = FakeMotionBase(speed_mps=2.0), FakeMapView()
    navigator = Navigator(parse_map(MAP), base, FakeEventSink(), TaskTable())
    yield Rig(base, view, navigator, build_mcp_server(navigator, map_view=view))
    await navigator.close()


def payload(result: Any) -> dict[str, Any]:
    assert not result.is_error
    value: dict[str, Any] = json.loads(result.content[0].text)
    return value


async def test_get_map_says_when_the_robot_publishes_none_then_serves_it(rig: Rig) -> None:
    async with Client(rig.server) as client:
        assert payload(await client.call_tool("get_map", {}))["available"] is False
        rig.view.publish_map(grid(ROOM))
        served = payload(await client.call_tool("get_map", {}))
    assert served["available"] is True
    assert (served["width"], served["height"]) == (6, 5)


async def test_get_plan_shows_the_plan_of_the_running_drive_only(rig: Rig) -> None:
    async with Client(rig.server) as client:
        rig.view.publish_plan([(0.0, 0.0), (1.0, 1.0)])  # an old plan, no drive
        assert payload(await client.call_tool("get_plan", {}))["points"] == []
        await client.call_tool("navigate_to", {"location": "hall"})
        assert payload(await client.call_tool("get_plan", {}))["points"] == []  # stale
        started = rig.navigator.drive_started_at()
        await async_wait_until(lambda: time.monotonic() > (started or 0.0), 5, "a clock tick")
        rig.view.publish_plan([(0.5, 0.5), (1.0, 0.5), (1.5, 0.5)])
        driving = payload(await client.call_tool("get_plan", {}))
        rig.base.arrive()
        await async_wait_until(lambda: not rig.navigator.pose()["moving"], 5, "the arrival")
        done = payload(await client.call_tool("get_plan", {}))
    assert driving == {
        "frame": "map",
        "points": [[0.5, 0.5], [1.0, 0.5], [1.5, 0.5]],
        "destination": "hall",
    }
    assert done["points"] == []
