"""A tiny MCP server through ``robot_mcp_kit.mcp_runtime.run_server`` (transport and credential
from the environment) for ``mcp_auth_overhead.py``: one tool that answers at once."""

from __future__ import annotations

from mcp.server.mcpserver import MCPServer

from robot_mcp_kit.logging import configure_logging
from robot_mcp_kit.mcp_runtime import run_server


def build() -> MCPServer:
    server = MCPServer("bench_echo", log_level="WARNING")

    @server.tool()
    async def echo(text: str) -> dict[str, str]:
        """Returns its input."""
        return {"text": text}

    return server


if __name__ == "__main__":
    configure_logging("bench_echo", level="WARNING")
    run_server(build(), default_port=9999)
