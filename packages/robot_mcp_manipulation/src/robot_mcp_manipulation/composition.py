"""The composition root: the only place adapters are built and wired."""

from __future__ import annotations

import time
from collections.abc import AsyncIterator, Callable
from contextlib import asynccontextmanager
from dataclasses import dataclass, field

import structlog
from mcp.server.mcpserver import MCPServer

from robot_mcp_kit import task_events
from robot_mcp_kit.supervision import Supervision
from robot_mcp_kit.supervision_tools import supervising
from robot_mcp_kit.task_events import EventSink
from robot_mcp_kit.tasks import TaskTable
from robot_mcp_manipulation.arm.port import ArmActions
from robot_mcp_manipulation.config import ConfigError, ManipulationSettings
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
    supervision: Supervision | None = None
    publish_lock: Callable[[], object] | None = None  # the dead-man lock, published now

    @asynccontextmanager
    async def running(self) -> AsyncIterator[ManipulationApp]:
        """Start the event sink and the supervision watchdog (a lapsed or latched lease stops
        the arm); on exit stop the arm and flush the events."""
        started = time.monotonic()
        await self.events.start()
        try:
            async with supervising(
                self.supervision,
                self.manipulator.stop,
                lambda: self.manipulator.moving,
                self.publish_lock,
            ):
                logger.info(
                    "manipulation_ready",
                    pick_action=self.settings.pick_action,
                    place_action=self.settings.place_action,
                    supervision=self.settings.supervision,
                    duration_ms=round((time.monotonic() - started) * 1000, 1),
                )
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
    return task_events.build_event_sink(
        SERVER_NAME,
        settings.events_url,
        settings.event_secret,
        settings.outbox_path,
        "MANIP_EVENT_SECRET",
    )


def build_arm(
    settings: ManipulationSettings, supervision: Supervision | None = None
) -> tuple[ArmActions, Callable[[], None], Callable[[], object] | None]:
    """The rclpy Pick/Place clients and the held subscription, with ``supervision`` the
    dead-man lock on ``MANIP_LOCK_TOPIC``; how to close them, and how to publish the lock now.

    Raises ConfigError (exit 2 at start-up) when rclpy or the interfaces cannot be imported.
    """
    try:
        from robot_mcp_manipulation.arm.rclpy_arm import RclpyArm
        from robot_ros_bridge import RosBridge
        from robot_ros_bridge.lock_publisher import SupervisorLockPublisher
    except ImportError as exc:
        raise ConfigError(
            f"the manipulation server needs rclpy and robot_manipulation_interfaces ({exc}): "
            "run `make setup`, or on a system ROS 2 build interfaces/robot_manipulation_interfaces "
            "with colcon and source its setup.bash"
        ) from exc
    bridge = RosBridge("robot_mcp_manipulation").start()
    try:
        arm = RclpyArm(bridge, settings.pick_action, settings.place_action, settings.held_topic)
        lock = None
        if supervision is not None:
            lock = SupervisorLockPublisher(
                bridge, supervision.locked, topic=settings.lock_topic, rate_hz=settings.lock_hz
            )
    except BaseException:
        bridge.close()
        raise

    def close() -> None:
        if lock is not None:
            lock.close()  # the lock falls silent first: twist_mux locks
        bridge.close()

    return arm, close, (lock.publish if lock is not None else None)


def build_app(
    settings: ManipulationSettings,
    *,
    arm: ArmActions | None = None,
    events: EventSink | None = None,
) -> ManipulationApp:
    closers: list[Callable[[], None]] = []
    supervision = Supervision(
        required=settings.supervision == "required", max_ttl_s=settings.lease_max_ttl_s
    )
    publish_lock = None
    if arm is None:
        # the lock only where it means something: a robot's twist_mux (or robot-sim)
        arm, close, publish_lock = build_arm(
            settings, supervision if supervision.required else None
        )
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
        gate=supervision,
    )
    server = build_mcp_server(manipulator, settings.log_level, settings.max_age_s, supervision)
    return ManipulationApp(
        settings, arm, events, manipulator, server, closers, supervision, publish_lock
    )
