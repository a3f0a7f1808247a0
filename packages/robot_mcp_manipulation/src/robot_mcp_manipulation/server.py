"""Process entry point: ``robot-mcp-manipulation`` (MCP_TRANSPORT stdio | sse | streamable-http)."""

from __future__ import annotations

from robot_mcp_kit.motion_serving import run_motion_server
from robot_mcp_manipulation.composition import build_app
from robot_mcp_manipulation.config import ConfigError, load_settings


def main() -> None:
    # stdio: fd 1 is the JSON-RPC wire alone; ROS's native start-up output goes to stderr
    run_motion_server("manipulation", load_settings, build_app, (ConfigError,), reserve_wire=True)
