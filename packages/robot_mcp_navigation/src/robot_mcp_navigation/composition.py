"""The composition root: the only place adapters are built and wired."""

from __future__ import annotations

from collections.abc import Awaitable, Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from mcp.server.mcpserver import MCPServer

from robot_mcp_kit.motion_serving import (
    MotionSide,
    MotionWiring,
    motion_event_sink,
    motion_supervision,
)
from robot_mcp_kit.supervision import (
    FOREIGN_GOAL_CLIENT,
    LOCK_TOPIC_SHARED,
    MAP_TOPIC_SHARED,
    POSE_TOPIC_SHARED,
    Supervision,
)
from robot_mcp_kit.task_events import EventSink
from robot_mcp_kit.tasks import TaskTable
from robot_mcp_navigation.config import ConfigError, NavigationSettings
from robot_mcp_navigation.confirmation import MotionConfirmer
from robot_mcp_navigation.map import NavMap, load_map
from robot_mcp_navigation.mapview.base import MapView, NoMapView
from robot_mcp_navigation.motion.base import MotionBase
from robot_mcp_navigation.motion.nav2.base import Nav2MotionBase
from robot_mcp_navigation.motion.nav2.port import Nav2Action
from robot_mcp_navigation.motion.simulated import PoseFile, SimulatedBase
from robot_mcp_navigation.navigator import Navigator, NavigatorSettings
from robot_mcp_navigation.tools import SERVER_NAME, build_mcp_server

if TYPE_CHECKING:  # imports rclpy: built only with NAV_MOTION=nav2
    from robot_ros_bridge.motion_side import MotionRosSide


@dataclass
class NavigationApp(MotionWiring):
    settings: NavigationSettings
    nav_map: NavMap
    base: MotionBase
    navigator: Navigator
    server: MCPServer


def build_motion_base(
    settings: NavigationSettings, nav_map: NavMap, nav2_action: Nav2Action | None = None
) -> MotionBase:
    """``NAV_MOTION``: the in-process simulated base, or Nav2 through its action."""
    start = nav_map.locations[nav_map.start].pose()
    if settings.motion == "simulated":
        return SimulatedBase(
            start=start,
            speed_mps=nav_map.speed_mps,
            time_scale=settings.time_scale,
            failures=nav_map.failures,
            tick_s=settings.tick_s,
            pose_file=PoseFile(settings.pose_path, nav_map.name),
        )
    assert nav2_action is not None, "NAV_MOTION=nav2 needs the Nav2 action adapter"
    return Nav2MotionBase(
        nav2_action,
        frame=nav_map.frame,
        speed_mps=nav_map.speed_mps,
        initial_pose=start,
        # The map's failures: are not injected with Nav2 (Nav2 decides what fails); their
        # suggestions (e.g. the detour around the mailroom door) go with Nav2's failures there.
        site_hints={f.location: tuple(f.suggestions) for f in nav_map.failures},
        server_timeout_s=settings.nav2_server_timeout_s,
        cancel_timeout_s=settings.nav2_cancel_timeout_s,
        feedback_timeout_s=settings.nav2_feedback_timeout_s,
        pose_max_age_s=settings.pose_max_age_s,
    )


def build_nav2_action(
    settings: NavigationSettings, supervision: Supervision | None = None
) -> tuple[Nav2Action, MapView, MotionRosSide]:
    """The rclpy NavigateToPose client, the pose, map, costmap and plan subscriptions — and,
    with ``supervision``, the dead-man lock on ``NAV_LOCK_TOPIC`` and the graph watcher that
    raises its alarms (issue 35) — and the ROS side that closes them.

    Raises ConfigError (exit 2 at start-up) when rclpy or nav2_msgs cannot be imported.
    """
    try:
        from robot_mcp_navigation.mapview.rclpy_view import RclpyMapView
        from robot_mcp_navigation.motion.nav2.rclpy_action import RclpyNav2Action
        from robot_ros_bridge.motion_side import DeadManLock, open_motion_side
    except ImportError as exc:
        raise ConfigError(
            f"NAV_MOTION=nav2 needs rclpy and nav2_msgs ({exc}): run `make setup`, or on a "
            "system ROS 2 source its setup.bash with ros-$ROS_DISTRO-nav2-msgs installed"
        ) from exc
    codes = (LOCK_TOPIC_SHARED, FOREIGN_GOAL_CLIENT)
    what = "the robot's dead-man lock"
    lock = DeadManLock.of(supervision, settings, codes, what) if supervision else None
    with open_motion_side("robot_mcp_navigation", lock).closed_on_error() as side:
        bridge = side.bridge
        action = RclpyNav2Action(bridge, settings.nav2_action, settings.pose_topic)
        view = RclpyMapView(bridge, settings.map_topic, settings.costmap_topic, settings.plan_topic)
        drive = "drive (NavigateToPose)"
        side.watch_goals(settings.nav2_action, action.sent, action.cancel_all_now, drive)
        if side.watcher is not None:
            watch_navigation_graph(side.watcher, settings)
    return action, view, side


def watch_navigation_graph(watcher: Any, settings: NavigationSettings) -> None:
    """What navigation watches on the ROS graph (issue 35) besides its own lock topic and its
    NavigateToPose goals: ``/amcl_pose`` and ``/map`` (one publisher each: the base's
    localisation and map server)."""
    watcher.watch_publishers(
        settings.pose_topic, POSE_TOPIC_SHARED, others_allowed=1, what="the robot's position"
    )
    watcher.watch_publishers(
        settings.map_topic, MAP_TOPIC_SHARED, others_allowed=1, what="the robot's map"
    )


def build_app(
    settings: NavigationSettings,
    *,
    base: MotionBase | None = None,
    events: EventSink | None = None,
    map_view: MapView | None = None,
) -> NavigationApp:
    nav_map = load_map(settings.map_path)
    if not settings.failures_enabled:
        nav_map = nav_map.without_failures()
    supervision = motion_supervision(settings, below=base is None and settings.motion == "nav2")
    view: MapView = map_view or NoMapView()
    side = None
    if base is None:
        nav2_action = None
        if settings.motion == "nav2":
            # the lock only where it means something: a robot's twist_mux (or robot-sim)
            locking = supervision if supervision.required else None
            nav2_action, view, ros = build_nav2_action(settings, locking)
            timeout_s = settings.nav2_cancel_timeout_s
            cancel_all = sweeper(nav2_action, timeout_s) if locking is not None else None
            side = MotionSide(ros.close, ros.publish_lock, cancel_all)
        base = build_motion_base(settings, nav_map, nav2_action)
    events = events or motion_event_sink(SERVER_NAME, settings, "NAV_EVENT_SECRET")
    navigator = Navigator(
        nav_map,
        base,
        events,
        TaskTable(SERVER_NAME),
        NavigatorSettings(
            time_scale=settings.time_scale,
            progress_interval_s=settings.progress_interval_s,
            progress_pct_step=settings.progress_pct_step,
        ),
        supervision=supervision,
    )
    confirmer = MotionConfirmer(nav_map) if settings.confirm_motion == "elicit" else None
    server = build_mcp_server(navigator, settings.log_level, confirmer, view)
    ready = {
        "map": nav_map.name,
        "locations": len(nav_map.locations),
        "failures": len(nav_map.failures),
        "motion": settings.motion,
        "time_scale": settings.time_scale,
    }
    return NavigationApp(
        settings,
        nav_map,
        base,
        navigator,
        server,
        name="navigation",
        service=navigator,
        events=events,
        supervision=supervision,
        side=side,
        ready=ready,
        prepare=base.cancel_stale_goals,  # before a lease can open the lock (issue 27)
    )


def sweeper(action: Nav2Action, timeout_s: float) -> Callable[[], Awaitable[bool]]:
    """The watchdog's cancel-all: True once Nav2 answered (it cancels all its goals)."""

    async def cancel_all() -> bool:
        return await action.cancel_all(timeout_s) is not None

    return cancel_all
