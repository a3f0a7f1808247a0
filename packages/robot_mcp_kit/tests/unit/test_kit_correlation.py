"""The mission id travels in a tools/call request's _meta and tags the server's log lines."""

from __future__ import annotations

import asyncio
from pathlib import Path
from typing import Any

import pytest
import structlog
from mcp import Client
from mcp.server.mcpserver import MCPServer

from robot_mcp_kit import EventPoster
from robot_mcp_kit.correlation import (
    MISSION_META_KEY,
    install_mission_correlation,
    mission_id_from,
    mission_meta,
)
from robot_mcp_kit.models import TaskEvent

tool_log = structlog.get_logger("test.tool")


def build_server(seen: list[dict[str, Any]]) -> MCPServer:
    server = MCPServer("correlation-test")

    @server.tool()
    async def navigate_to(location: str) -> dict[str, str]:
        """Logs one line and records the log context the tool ran under."""
        seen.append(dict(structlog.contextvars.get_contextvars()))
        tool_log.info("navigating", location=location)
        return {"location": location}

    return server


async def test_a_call_with_a_mission_id_logs_under_it_and_a_call_without_does_not() -> None:
    seen: list[dict[str, Any]] = []
    server = install_mission_correlation(build_server(seen))
    install_mission_correlation(server)  # idempotent
    with structlog.testing.capture_logs() as logs:
        async with Client(server) as client:
            await client.call_tool(
                "navigate_to", {"location": "mailroom"}, meta=mission_meta("m-1a2b3c")
            )
            await client.call_tool("navigate_to", {"location": "kitchen"})
    assert seen[0].get("mission_id") == "m-1a2b3c"
    assert "mission_id" not in seen[1]
    assert {"event": "mcp_tool_call", "tool": "navigate_to", "log_level": "info"}.items() <= logs[
        0
    ].items()
    assert [e["location"] for e in logs if e["event"] == "navigating"] == ["mailroom", "kitchen"]


@pytest.mark.parametrize(
    ("meta", "expected"),
    [
        ({MISSION_META_KEY: "m-6a5562"}, "m-6a5562"),
        ({MISSION_META_KEY: "m-1\nforged"}, None),
        ({MISSION_META_KEY: "x" * 65}, None),
        ({MISSION_META_KEY: 42}, None),
        ({"progress_token": 1}, None),
        (None, None),
    ],
)
def test_only_a_plain_short_mission_id_is_accepted(meta: Any, expected: str | None) -> None:
    assert mission_id_from(meta) == expected


def test_no_mission_means_no_meta() -> None:
    assert mission_meta(None) is None
    assert mission_meta("") is None
    assert mission_meta("m-1") == {MISSION_META_KEY: "m-1"}


async def test_events_posted_for_a_mission_call_name_the_mission(tmp_path: Path) -> None:
    events: list[TaskEvent] = []
    server = install_mission_correlation(MCPServer("events-test"))
    poster = EventPoster("http://127.0.0.1:1/e", "navigation", "s", tmp_path / "outbox.sqlite")
    await poster.start()

    @server.tool()
    async def navigate_to(location: str) -> dict[str, str]:
        """Starts a drive whose later event is posted from a task of its own."""

        async def drive() -> None:
            events.append(await poster.emit("nav-1", "navigate_to", "progress", {"pct": 10}))

        await asyncio.create_task(drive())
        return {"task_id": "nav-1"}

    try:
        async with Client(server) as client:
            await client.call_tool(
                "navigate_to", {"location": "mailroom"}, meta=mission_meta("m-77")
            )
            await client.call_tool("navigate_to", {"location": "kitchen"})
        outside = await poster.emit("nav-2", "navigate_to", "progress", {})
    finally:
        await poster.close(flush_timeout_s=0.1)
    assert events[0].payload == {"pct": 10, "mission_id": "m-77"}
    assert events[1].payload == {"pct": 10}
    assert "mission_id" not in outside.payload
