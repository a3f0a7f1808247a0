"""A tiny MCP server run through robot_mcp_kit.mcp_runtime.run_server (transport from env).

``KIT_PROC_NOISE=1`` makes it behave like a process with a native library that writes to fd 1
at start-up, in a tool and at shutdown (as rcl / Fast DDS may); ``KIT_PROC_RESERVE=1`` makes it
reserve stdout for the protocol first, as the ROS servers do.
"""

from __future__ import annotations

import os
import sys

from mcp.server.mcpserver import MCPServer

from robot_mcp_kit.caller import current_caller
from robot_mcp_kit.logging import configure_logging
from robot_mcp_kit.mcp_runtime import reserve_stdout, run_server, tool_error

NOISE = os.environ.get("KIT_PROC_NOISE") == "1"


def native_print(text: str) -> None:
    if NOISE:
        os.write(1, f"[native] {text}\n".encode())


def build() -> MCPServer:
    server = MCPServer("kit-proc")

    @server.tool()
    async def fail(code: str, detail: str) -> str:
        """Always fails with the given error."""
        raise tool_error(code, detail)

    @server.tool()
    async def echo(text: str) -> str:
        """Returns its input."""
        native_print("in a tool")
        return text

    @server.tool()
    async def whoami() -> str:
        """The principal the transport proved for this call."""
        return current_caller().principal

    return server


if __name__ == "__main__":
    wire = reserve_stdout() if os.environ.get("KIT_PROC_RESERVE") == "1" else None
    configure_logging("kit-proc")
    native_print("at start-up")
    try:
        run_server(build(), default_port=9999, wire=wire)
    finally:
        native_print("at shutdown")
    sys.stderr.write("cleaned up\n")  # only after a clean return from run_server
