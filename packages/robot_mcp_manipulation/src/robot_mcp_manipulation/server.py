"""Process entry point: ``robot-mcp-manipulation`` (MCP_TRANSPORT stdio | sse | streamable-http)."""

from __future__ import annotations

import asyncio
import os
import signal
import sys
from types import FrameType
from typing import BinaryIO

import structlog

from robot_mcp_kit.logging import configure_logging
from robot_mcp_kit.mcp_runtime import TransportSettings, reserve_stdout, serve_mcp
from robot_mcp_kit.service_auth import ServiceAuth, ServiceAuthError, service_auth
from robot_mcp_manipulation.composition import ManipulationApp, build_app
from robot_mcp_manipulation.config import ConfigError, load_settings

logger = structlog.get_logger(__name__)


async def serve(
    app: ManipulationApp, wire: BinaryIO | None = None, auth: ServiceAuth | None = None
) -> None:
    """Run the MCP transport until it stops; the arm is stopped and events flushed after.
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
            wire,
        )


def _interrupt(signum: int, frame: FrameType | None) -> None:
    raise KeyboardInterrupt


def main() -> None:
    wire: BinaryIO | None = None
    try:
        settings = load_settings(os.environ)
        configure_logging("manipulation", level=settings.log_level)
        # stdio: fd 1 is the JSON-RPC wire alone; ROS's native start-up output goes to stderr
        auth = service_auth(os.environ, settings.transport)
        wire = reserve_stdout() if settings.transport == "stdio" else None
        app = build_app(settings)
    except (ConfigError, ServiceAuthError) as exc:
        configure_logging("manipulation")
        logger.error("startup_failed", detail=str(exc))
        sys.exit(2)
    # SIGTERM (systemd stop) takes the same clean path as Ctrl-C: stop the arm, flush, exit.
    signal.signal(signal.SIGTERM, _interrupt)
    try:
        asyncio.run(serve(app, wire, auth))
    except KeyboardInterrupt:
        logger.info("manipulation_interrupted")
