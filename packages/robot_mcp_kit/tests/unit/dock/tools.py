"""Step 4 of the recipe: the dock's MCP surface — its one motion tool behind the kit's guard,
the kit's stop tool and task tools, and the brain's ``supervise`` tool when supervised."""

from __future__ import annotations

from typing import Any

from mcp.server.mcpserver import MCPServer

from robot_mcp_kit.annotations import MOVES_ROBOT
from robot_mcp_kit.motion_tools import add_stop_tool, add_task_tools, guard, motion_server
from robot_mcp_kit.supervision import Supervision

from .docking import Docker


def build_mcp_server(docker: Docker, supervision: Supervision | None = None) -> MCPServer:
    server = motion_server("dock", supervision=supervision)

    @server.tool(annotations=MOVES_ROBOT)
    async def dock() -> dict[str, Any]:
        """Drive onto the charging dock; a TaskInfo at once, then task events."""
        info = await guard(docker.dock())
        return info.model_dump(mode="json")

    add_stop_tool(
        server,
        "stop_docking",
        "Stop docking now.",
        docker.stop,
        lambda: {"moving": docker.moving},
    )
    add_task_tools(server, docker, "docking", "the robot stops")
    return server
