"""The composition root: the only place adapters are built and wired."""

from __future__ import annotations

from collections.abc import AsyncIterator, Awaitable, Callable
from contextlib import asynccontextmanager
from dataclasses import dataclass, field
from typing import Any

from mcp.server.mcpserver import MCPServer

from robot_mcp_kit import task_events
from robot_mcp_kit.motion_serving import motion_running
from robot_mcp_kit.supervision import FOREIGN_GOAL_CLIENT, LOCK_TOPIC_SHARED, Supervision
from robot_mcp_kit.task_events import EventSink
from robot_mcp_kit.tasks import TaskTable
from robot_mcp_manipulation.arm.port import ArmActions
from robot_mcp_manipulation.config import ConfigError, ManipulationSettings
from robot_mcp_manipulation.manipulator import Manipulator, ManipulatorSettings
from robot_mcp_manipulation.tools import SERVER_NAME, build_mcp_server


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
    cancel_all: Callable[[], Awaitable[bool]] | None = None  # every Pick/Place goal (issue 35)

    @asynccontextmanager
    async def running(self) -> AsyncIterator[ManipulationApp]:
        """Start the event sink and the supervision watchdog (a lapsed or latched lease stops
        the arm); on exit stop the arm and flush the events."""
        async with motion_running(
            "manipulation",
            self.events,
            self.manipulator,
            supervision=self.supervision,
            publish_lock=self.publish_lock,
            cancel_all=self.cancel_all,
            closers=self.closers,
            ready={
                "pick_action": self.settings.pick_action,
                "place_action": self.settings.place_action,
                "supervision": self.settings.supervision,
            },
        ):
            yield self


def build_event_sink(settings: ManipulationSettings) -> EventSink:
    """Signed posts to the brain when a secret is configured, else log-only (documented)."""
    return task_events.build_event_sink(
        SERVER_NAME,
        settings.events_url,
        settings.event_secret,
        settings.outbox_path,
        "MANIP_EVENT_SECRET",
    )


@dataclass
class ArmSide:
    """The rclpy arm and, with supervision, its lock, graph watcher and cancel-all."""

    arm: ArmActions
    close: Callable[[], None]
    publish_lock: Callable[[], object] | None = None
    cancel_all: Callable[[], Awaitable[bool]] | None = None


def build_arm(settings: ManipulationSettings, supervision: Supervision | None = None) -> ArmSide:
    """The rclpy Pick/Place clients and the held subscription — with ``supervision`` the
    dead-man lock on ``MANIP_LOCK_TOPIC``, the graph watcher raising its alarms (a second
    publisher on the lock topic; a Pick/Place goal not ours, or another client, while motion is
    refused) and the cancel-all of every Pick/Place goal (issue 35) — and how to close them.

    Raises ConfigError (exit 2 at start-up) when rclpy or the interfaces cannot be imported.
    """
    try:
        from robot_mcp_manipulation.arm.rclpy_arm import RclpyArm
        from robot_ros_bridge.motion_side import DeadManLock, open_motion_side
    except ImportError as exc:
        raise ConfigError(
            f"the manipulation server needs rclpy and robot_manipulation_interfaces ({exc}): "
            "run `make setup`, or on a system ROS 2 build interfaces/robot_manipulation_interfaces "
            "with colcon and source its setup.bash"
        ) from exc
    lock = None
    if supervision is not None:
        lock = DeadManLock(
            settings.lock_topic,
            settings.lock_hz,
            supervision.locked,
            supervision.raise_alarm,
            LOCK_TOPIC_SHARED,
            "the arm's dead-man lock",
        )
    side = open_motion_side("robot_mcp_manipulation", lock)
    try:
        arm = RclpyArm(
            side.bridge, settings.pick_action, settings.place_action, settings.held_topic
        )
        if supervision is not None and side.watcher is not None:
            watch_arm_graph(side.watcher, settings, supervision, arm)
    except BaseException:
        side.close()
        raise
    if side.lock is None:
        return ArmSide(arm, side.close)

    async def cancel_all() -> bool:
        return await arm.cancel_all(settings.cancel_timeout_s)

    return ArmSide(arm, side.close, side.publish_lock, cancel_all)


def watch_arm_graph(
    watcher: Any, settings: ManipulationSettings, supervision: Supervision, arm: Any
) -> None:
    """What manipulation watches (issue 35) besides its own lock topic: the Pick and Place
    actions while motion is refused."""
    for action, what in zip(arm.action_names, ("pick", "place"), strict=True):
        watcher.watch_goals(
            action,
            FOREIGN_GOAL_CLIENT,
            ours=arm.sent,
            stopped=lambda: supervision.refusal() is not None,
            cancel_all_now=arm.cancel_all_now,
            allowed_clients=settings.allowed_goal_clients,
            what=f"arm ({what})",
        )


def build_app(
    settings: ManipulationSettings,
    *,
    arm: ArmActions | None = None,
    events: EventSink | None = None,
) -> ManipulationApp:
    closers: list[Callable[[], None]] = []
    required = settings.supervision == "required"
    # with the robot's arm below a supervised server, every stop cancels all its goals, and the
    # lock opens again only after that sweep (issue 35)
    supervision = Supervision(
        required=required, max_ttl_s=settings.lease_max_ttl_s, sweeps=required and arm is None
    )
    publish_lock = None
    cancel_all = None
    if arm is None:
        # the lock only where it means something: a robot's twist_mux (or robot-sim)
        side = build_arm(settings, supervision if supervision.required else None)
        arm, publish_lock, cancel_all = side.arm, side.publish_lock, side.cancel_all
        closers.append(side.close)
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
        settings, arm, events, manipulator, server, closers, supervision, publish_lock, cancel_all
    )
