"""Process entry point: ``robot-mcp-navigation`` (MCP_TRANSPORT stdio | sse | streamable-http)."""

from __future__ import annotations

from robot_mcp_kit.motion_serving import run_motion_server
from robot_mcp_navigation.composition import build_app
from robot_mcp_navigation.config import ConfigError, load_settings
from robot_mcp_navigation.map import MapError


def main() -> None:
    run_motion_server("navigation", load_settings, build_app, (ConfigError, MapError))
