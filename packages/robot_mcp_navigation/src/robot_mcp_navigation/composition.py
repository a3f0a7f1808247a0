"""The composition root: the only place adapters are built and wired."""

from __future__ import annotations

from collections.abc import AsyncIterator, Awaitable, Callable
from contextlib import asynccontextmanager
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from mcp.server.mcpserver import MCPServer

from robot_mcp_kit import task_events
from robot_mcp_kit.motion_serving import motion_running
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
class NavigationApp:
    settings: NavigationSettings
    nav_map: NavMap
    base: MotionBase
    events: EventSink
    navigator: Navigator
    server: MCPServer
    closers: list[Callable[[], None]] = field(default_factory=list)
    supervision: Supervision | None = None
    publish_lock: Callable[[], object] | None = None  # the dead-man lock, published now
    cancel_all: Callable[[], Awaitable[bool]] | None = None  # every goal below (issue 35)

    @asynccontextmanager
    async def running(self) -> AsyncIterator[NavigationApp]:
        """Start the event sink and the supervision watchdog; on exit halt the robot and flush
        the events."""
        async with motion_running(
            "navigation",
            self.events,
            self.navigator,
            supervision=self.supervision,
            publish_lock=self.publish_lock,
            cancel_all=self.cancel_all,
            closers=self.closers,
            prepare=self.base.cancel_stale_goals,  # before a lease can open the lock (issue 27)
            ready={
                "map": self.nav_map.name,
                "locations": len(self.nav_map.locations),
                "failures": len(self.nav_map.failures),
                "motion": self.settings.motion,
                "time_scale": self.settings.time_scale,
            },
        ):
            yield self


def build_event_sink(settings: NavigationSettings) -> EventSink:
    """Signed posts to the brain when a secret is configured, else log-only (documented)."""
    return task_events.build_event_sink(
        SERVER_NAME,
        settings.events_url,
        settings.event_secret,
        settings.outbox_path,
        "NAV_EVENT_SECRET",
    )


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
    lock = None
    if supervision is not None:
        lock = DeadManLock(
            settings.lock_topic,
            settings.lock_hz,
            supervision.locked,
            supervision.raise_alarm,
            LOCK_TOPIC_SHARED,
            "the robot's dead-man lock",
        )
    side = open_motion_side("robot_mcp_navigation", lock)
    try:
        bridge = side.bridge
        action = RclpyNav2Action(bridge, settings.nav2_action, settings.pose_topic)
        view = RclpyMapView(bridge, settings.map_topic, settings.costmap_topic, settings.plan_topic)
        if supervision is not None and side.watcher is not None:
            watch_navigation_graph(side.watcher, settings, supervision, action)
    except BaseException:
        side.close()
        raise
    return action, view, side


def watch_navigation_graph(
    watcher: Any, settings: NavigationSettings, supervision: Supervision, action: Any
) -> None:
    """What navigation watches on the ROS graph (issue 35) besides its own lock topic:
    ``/amcl_pose`` and ``/map`` (one publisher each: the base's localisation and map server),
    and the NavigateToPose action while motion is refused (a goal not ours, or another client
    of it, is cancelled and alarmed)."""
    watcher.watch_publishers(
        settings.pose_topic, POSE_TOPIC_SHARED, others_allowed=1, what="the robot's position"
    )
    watcher.watch_publishers(
        settings.map_topic, MAP_TOPIC_SHARED, others_allowed=1, what="the robot's map"
    )
    watcher.watch_goals(
        settings.nav2_action,
        FOREIGN_GOAL_CLIENT,
        ours=action.sent,
        stopped=lambda: supervision.refusal() is not None,
        cancel_all_now=action.cancel_all_now,
        allowed_clients=settings.allowed_goal_clients,
        what="drive (NavigateToPose)",
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
    closers: list[Callable[[], None]] = []
    required = settings.supervision == "required"
    # with Nav2 below a supervised server, every stop cancels all its goals, and the lock opens
    # again only after that sweep (issue 35)
    supervision = Supervision(
        required=required,
        max_ttl_s=settings.lease_max_ttl_s,
        sweeps=required and base is None and settings.motion == "nav2",
    )
    view: MapView = map_view or NoMapView()
    publish_lock = None
    cancel_all = None
    if base is None:
        nav2_action = None
        if settings.motion == "nav2":
            # the lock only where it means something: a robot's twist_mux (or robot-sim)
            locking = supervision if supervision.required else None
            nav2_action, view, ros = build_nav2_action(settings, locking)
            closers.append(ros.close)
            publish_lock = ros.publish_lock
            if locking is not None:
                cancel_all = sweeper(nav2_action, settings.nav2_cancel_timeout_s)
        base = build_motion_base(settings, nav_map, nav2_action)
    events = events or build_event_sink(settings)
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
    return NavigationApp(
        settings,
        nav_map,
        base,
        events,
        navigator,
        build_mcp_server(navigator, settings.log_level, confirmer, view),
        closers,
        supervision,
        publish_lock,
        cancel_all,
    )


def sweeper(action: Nav2Action, timeout_s: float) -> Callable[[], Awaitable[bool]]:
    """The watchdog's cancel-all: True once Nav2 answered (it cancels all its goals)."""

    async def cancel_all() -> bool:
        return await action.cancel_all(timeout_s) is not None

    return cancel_all
