"""Process entry point: ``robot-mcp-navigation`` (MCP_TRANSPORT stdio | sse | streamable-http)."""

from __future__ import annotations

import asyncio
import os
import signal
import sys
from types import FrameType

import structlog

from robot_mcp_kit.logging import configure_logging
from robot_mcp_kit.mcp_runtime import TransportSettings, serve_mcp
from robot_mcp_kit.service_auth import ServiceAuth, ServiceAuthError, service_auth
from robot_mcp_navigation.composition import NavigationApp, build_app
from robot_mcp_navigation.config import ConfigError, load_settings
from robot_mcp_navigation.map import MapError

logger = structlog.get_logger(__name__)


async def serve(app: NavigationApp, auth: ServiceAuth | None = None) -> None:
    """Run the MCP transport until it stops; the robot is halted and events flushed after.
    ``auth``: the HTTP transports' credentials (None: read from the environment)."""
    settings = app.settings
    async with app.running():
        logger.info(
            "mcp_server_starting",
            transport=settings.transport,
            host=settings.host,
            port=settings.port,
        )
        await serve_mcp(
            app.server,
            TransportSettings(settings.transport, settings.host, settings.port, auth),
        )


def _interrupt(signum: int, frame: FrameType | None) -> None:
    raise KeyboardInterrupt


def main() -> None:
    try:
        settings = load_settings(os.environ)
        configure_logging("navigation", level=settings.log_level)
        auth = service_auth(os.environ, settings.transport)
        app = build_app(settings)
    except (ConfigError, MapError, ServiceAuthError) as exc:
        configure_logging("navigation")
        logger.error("startup_failed", detail=str(exc))
        sys.exit(2)
    # SIGTERM (systemd stop) takes the same clean path as Ctrl-C: halt, flush, exit.
    signal.signal(signal.SIGTERM, _interrupt)
    try:
        asyncio.run(serve(app, auth))
    except KeyboardInterrupt:
        logger.info("navigation_interrupted")
