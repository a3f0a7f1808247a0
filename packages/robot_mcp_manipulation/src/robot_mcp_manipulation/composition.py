"""The composition root: the only place adapters are built and wired."""

from __future__ import annotations

from dataclasses import dataclass

from mcp.server.mcpserver import MCPServer

from robot_mcp_kit.motion_serving import (
    MotionSide,
    MotionWiring,
    motion_event_sink,
    motion_supervision,
)
from robot_mcp_kit.supervision import FOREIGN_GOAL_CLIENT, LOCK_TOPIC_SHARED, Supervision
from robot_mcp_kit.task_events import EventSink
from robot_mcp_kit.tasks import TaskTable
from robot_mcp_manipulation.arm.port import ArmActions
from robot_mcp_manipulation.config import ConfigError, ManipulationSettings
from robot_mcp_manipulation.manipulator import Manipulator, ManipulatorSettings
from robot_mcp_manipulation.tools import SERVER_NAME, build_mcp_server


@dataclass
class ManipulationApp(MotionWiring):
    settings: ManipulationSettings
    arm: ArmActions
    manipulator: Manipulator
    server: MCPServer


def build_arm(
    settings: ManipulationSettings, supervision: Supervision | None = None
) -> tuple[ArmActions, MotionSide]:
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
    codes = (LOCK_TOPIC_SHARED, FOREIGN_GOAL_CLIENT)
    what = "the arm's dead-man lock"
    lock = DeadManLock.of(supervision, settings, codes, what) if supervision else None
    with open_motion_side("robot_mcp_manipulation", lock).closed_on_error() as side:
        arm = RclpyArm(
            side.bridge, settings.pick_action, settings.place_action, settings.held_topic
        )
        for action, kind in zip(arm.action_names, ("pick", "place"), strict=True):
            side.watch_goals(action, arm.sent, arm.cancel_all_now, f"arm ({kind})")
    if side.lock is None:
        return arm, MotionSide(side.close)

    async def cancel_all() -> bool:
        return await arm.cancel_all(settings.cancel_timeout_s)

    return arm, MotionSide(side.close, side.publish_lock, cancel_all)


def build_app(
    settings: ManipulationSettings,
    *,
    arm: ArmActions | None = None,
    events: EventSink | None = None,
) -> ManipulationApp:
    supervision = motion_supervision(settings, below=arm is None)
    side = None
    if arm is None:
        # the lock only where it means something: a robot's twist_mux (or robot-sim)
        arm, side = build_arm(settings, supervision if supervision.required else None)
    events = events or motion_event_sink(SERVER_NAME, settings, "MANIP_EVENT_SECRET")
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
    actions = {"pick_action": settings.pick_action, "place_action": settings.place_action}
    return ManipulationApp(
        settings,
        arm,
        manipulator,
        server,
        name="manipulation",
        service=manipulator,
        events=events,
        supervision=supervision,
        side=side,
        ready={**actions, "supervision": settings.supervision},
    )
