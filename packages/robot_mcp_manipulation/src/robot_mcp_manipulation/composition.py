"""The composition root: the only place adapters are built and wired."""

from __future__ import annotations

import time
from collections.abc import AsyncIterator, Callable
from contextlib import asynccontextmanager
from dataclasses import dataclass, field

import structlog
from mcp.server.mcpserver import MCPServer

from robot_mcp_kit.poster import EventPoster
from robot_mcp_kit.tasks import TaskTable
from robot_mcp_manipulation.arm.port import ArmActions
from robot_mcp_manipulation.config import ConfigError, ManipulationSettings
from robot_mcp_manipulation.events.base import EventSink
from robot_mcp_manipulation.events.log_only import LogOnlyEventSink
from robot_mcp_manipulation.events.poster import PosterEventSink
from robot_mcp_manipulation.manipulator import Manipulator, ManipulatorSettings
from robot_mcp_manipulation.tools import SERVER_NAME, build_mcp_server

logger = structlog.get_logger(__name__)


@dataclass
class ManipulationApp:
    settings: ManipulationSettings
    arm: ArmActions
    events: EventSink
    manipulator: Manipulator
    server: MCPServer
    closers: list[Callable[[], None]] = field(default_factory=list)

    @asynccontextmanager
    async def running(self) -> AsyncIterator[ManipulationApp]:
        """Start the event sink; on exit stop the arm and flush the events."""
        started = time.monotonic()
        await self.events.start()
        logger.info(
            "manipulation_ready",
            pick_action=self.settings.pick_action,
            place_action=self.settings.place_action,
            duration_ms=round((time.monotonic() - started) * 1000, 1),
        )
        try:
            yield self
        finally:
            try:
                await self.manipulator.close()
                await self.events.close()
            finally:
                for close in self.closers:
                    close()
            logger.info("manipulation_shutdown")


def build_event_sink(settings: ManipulationSettings) -> EventSink:
    """Signed posts to the brain when a secret is configured, else log-only (documented)."""
    if settings.event_secret is None:
        return LogOnlyEventSink()
    settings.outbox_path.parent.mkdir(parents=True, exist_ok=True)
    poster = EventPoster(
        settings.events_url,
        SERVER_NAME,
        settings.event_secret.get_secret_value(),
        settings.outbox_path,
    )
    return PosterEventSink(poster)


def build_arm(settings: ManipulationSettings) -> tuple[ArmActions, Callable[[], None]]:
    """The rclpy Pick/Place clients and the held subscription, and how to close them.

    Raises ConfigError (exit 2 at start-up) when rclpy or the interfaces cannot be imported.
    """
    try:
        from robot_mcp_manipulation.arm.rclpy_arm import RclpyArm
        from robot_ros_bridge import RosBridge
    except ImportError as exc:
        raise ConfigError(
            f"the manipulation server needs rclpy and robot_manipulation_interfaces ({exc}): "
            "run `make setup`, or on a system ROS 2 build interfaces/robot_manipulation_interfaces "
            "with colcon and source its setup.bash"
        ) from exc
    bridge = RosBridge("robot_mcp_manipulation").start()
    try:
        arm = RclpyArm(bridge, settings.pick_action, settings.place_action, settings.held_topic)
    except BaseException:
        bridge.close()
        raise
    return arm, bridge.close


def build_app(
    settings: ManipulationSettings,
    *,
    arm: ArmActions | None = None,
    events: EventSink | None = None,
) -> ManipulationApp:
    closers: list[Callable[[], None]] = []
    if arm is None:
        arm, close = build_arm(settings)
        closers.append(close)
    events = events or build_event_sink(settings)
    manipulator = Manipulator(
        arm,
        events,
        TaskTable(SERVER_NAME),
        ManipulatorSettings(
            server_timeout_s=settings.server_timeout_s,
            cancel_timeout_s=settings.cancel_timeout_s,
            task_timeout_s=settings.task_timeout_s,
        ),
    )
    server = build_mcp_server(manipulator, settings.log_level, settings.max_age_s)
    return ManipulationApp(settings, arm, events, manipulator, server, closers)
