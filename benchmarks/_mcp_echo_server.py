"""A tiny MCP server for ``mcp_auth_overhead.py``: one tool that answers at once, served by
ONE process on two loopback ports through ``robot_mcp_kit.mcp_runtime.http_app`` — behind the
credential check on ``BENCH_PORT_CHECKED`` (``MCP_AUTH_TOKEN`` from the environment) and
without it on ``BENCH_PORT_OPEN`` — so both paths share the process, its event loop and the
same MCP server object.
"""

from __future__ import annotations

import asyncio
import os

import uvicorn
from mcp.server.mcpserver import MCPServer

from robot_mcp_kit.caller import install_caller_context
from robot_mcp_kit.correlation import install_mission_correlation
from robot_mcp_kit.logging import configure_logging
from robot_mcp_kit.mcp_runtime import (
    TransportSettings,
    http_app,
    install_json_tool_errors,
    transport_settings,
)
from robot_mcp_kit.service_auth import ServiceAuth


def build() -> MCPServer:
    server = MCPServer("bench_echo", log_level="WARNING")

    @server.tool()
    async def echo(text: str) -> dict[str, str]:
        """Returns its input."""
        return {"text": text}

    # what serve_mcp installs, so both ports run the served stack
    install_caller_context(install_mission_correlation(install_json_tool_errors(server)))
    return server


async def serve() -> None:
    server = build()
    checked = transport_settings(os.environ, int(os.environ["BENCH_PORT_CHECKED"]))
    open_ = TransportSettings(
        checked.transport, checked.host, int(os.environ["BENCH_PORT_OPEN"]), ServiceAuth()
    )
    servers = [
        uvicorn.Server(
            uvicorn.Config(http_app(server, s), host=s.host, port=s.port, log_level="warning")
        )
        for s in (checked, open_)
    ]
    await asyncio.gather(*(s.serve() for s in servers))


if __name__ == "__main__":
    configure_logging("bench_echo", level="WARNING")
    asyncio.run(serve())
