"""The composition root: the only place adapters are built and wired."""

from __future__ import annotations

import time
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from dataclasses import dataclass

import structlog
from mcp.server.mcpserver import MCPServer

from robot_mcp_kit.poster import EventPoster
from robot_mcp_kit.tasks import TaskTable
from robot_mcp_navigation.config import NavigationSettings
from robot_mcp_navigation.confirmation import MotionConfirmer
from robot_mcp_navigation.events.base import EventSink
from robot_mcp_navigation.events.log_only import LogOnlyEventSink
from robot_mcp_navigation.events.poster import PosterEventSink
from robot_mcp_navigation.map import NavMap, load_map
from robot_mcp_navigation.motion.base import MotionBase
from robot_mcp_navigation.motion.simulated import SimulatedBase
from robot_mcp_navigation.navigator import Navigator, NavigatorSettings
from robot_mcp_navigation.tools import SERVER_NAME, build_mcp_server

logger = structlog.get_logger(__name__)


@dataclass
class NavigationApp:
    settings: NavigationSettings
    nav_map: NavMap
    base: MotionBase
    events: EventSink
    navigator: Navigator
    server: MCPServer

    @asynccontextmanager
    async def running(self) -> AsyncIterator[NavigationApp]:
        """Start the event sink; on exit halt the robot and flush the events."""
        started = time.monotonic()
        await self.events.start()
        logger.info(
            "navigation_ready",
            map=self.nav_map.name,
            locations=len(self.nav_map.locations),
            failures=len(self.nav_map.failures),
            time_scale=self.settings.time_scale,
            duration_ms=round((time.monotonic() - started) * 1000, 1),
        )
        try:
            yield self
        finally:
            await self.navigator.close()
            await self.events.close()
            logger.info("navigation_shutdown")


def build_event_sink(settings: NavigationSettings) -> EventSink:
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


def build_motion_base(settings: NavigationSettings, nav_map: NavMap) -> MotionBase:
    """The simulated base; a real base adapter is wired in here instead."""
    return SimulatedBase(
        start=nav_map.locations[nav_map.start].pose(),
        speed_mps=nav_map.speed_mps,
        time_scale=settings.time_scale,
        failures=nav_map.failures,
        tick_s=settings.tick_s,
    )


def build_app(
    settings: NavigationSettings,
    *,
    base: MotionBase | None = None,
    events: EventSink | None = None,
) -> NavigationApp:
    nav_map = load_map(settings.map_path)
    if not settings.failures_enabled:
        nav_map = nav_map.without_failures()
    base = base or build_motion_base(settings, nav_map)
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
    )
    confirmer = MotionConfirmer(nav_map) if settings.confirm_motion == "elicit" else None
    return NavigationApp(
        settings,
        nav_map,
        base,
        events,
        navigator,
        build_mcp_server(navigator, settings.log_level, confirmer),
    )
