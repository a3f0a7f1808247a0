"""The mission id travels in a tools/call request's _meta and tags the server's log lines."""

from __future__ import annotations

from typing import Any

import pytest
import structlog
from mcp import Client
from mcp.server.mcpserver import MCPServer

from robot_mcp_kit.correlation import (
    MISSION_META_KEY,
    install_mission_correlation,
    mission_id_from,
    mission_meta,
)

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
