"""A tiny MCP server run through robot_mcp_kit.mcp_runtime.run_server (transport from env)."""

from __future__ import annotations

from mcp.server.mcpserver import MCPServer

from robot_mcp_kit.logging import configure_logging
from robot_mcp_kit.mcp_runtime import run_server, tool_error


def build() -> MCPServer:
    server = MCPServer("kit-proc")

    @server.tool()
    async def fail(code: str, detail: str) -> str:
        """Always fails with the given error."""
        raise tool_error(code, detail)

    @server.tool()
    async def echo(text: str) -> str:
        """Returns its input."""
        return text

    return server


if __name__ == "__main__":
    configure_logging("kit-proc")
    run_server(build(), default_port=9999)
