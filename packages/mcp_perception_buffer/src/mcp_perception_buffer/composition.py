"""The composition root of the ``mcp-perception-buffer`` process: the only place adapters are
built.

The perception service (graph polling, watcher arming, the event poster) runs on its own
event loop in a daemon thread for the life of the process, independent of the MCP transport
(whose sessions come and go); tools reach it thread-safely.
"""

from __future__ import annotations

import asyncio
import os
import threading
from collections.abc import Coroutine
from dataclasses import dataclass, field
from typing import Any, TypeVar

from mcp.server.mcpserver import MCPServer

from mcp_perception_buffer.buffer import RollingBuffer
from mcp_perception_buffer.config import DEFAULT_PORT, SERVER_NAME, PerceptionConfig
from mcp_perception_buffer.events import EventSink, LoggingEventSink, PosterEventSink
from mcp_perception_buffer.ros_side import TopicFollower
from mcp_perception_buffer.server import build_server
from mcp_perception_buffer.service import Perception
from mcp_perception_buffer.watchers import WatcherService
from robot_mcp_kit.logging import configure_logging
from robot_mcp_kit.mcp_runtime import reserve_stdout, run_server, transport_settings
from robot_mcp_kit.outbox import OutboxError
from robot_mcp_kit.startup import refuse_to_start
from robot_ros_bridge import RosBridge
from robot_ros_bridge.vision_tasks import RosVisionTasks, VisionTasks

T = TypeVar("T")
SERVICE = "mcp-perception-buffer"


class BackgroundLoop:
    """An asyncio loop in a daemon thread; ``run(coro)`` blocks the caller until done."""

    def __init__(self, name: str = "perception-loop") -> None:
        self.loop = asyncio.new_event_loop()
        self._thread = threading.Thread(target=self.loop.run_forever, name=name, daemon=True)
        self._thread.start()

    def run(self, coro: Coroutine[Any, Any, T], timeout_s: float = 30.0) -> T:
        return asyncio.run_coroutine_threadsafe(coro, self.loop).result(timeout_s)

    def stop(self) -> None:
        self.loop.call_soon_threadsafe(self.loop.stop)
        self._thread.join(timeout=5.0)
        if not self._thread.is_alive():
            self.loop.close()


@dataclass
class PerceptionApp:
    config: PerceptionConfig
    server: MCPServer
    perception: Perception
    buffer: RollingBuffer
    bridge: RosBridge | None
    _background: BackgroundLoop | None = field(default=None, repr=False)

    def start_background(self) -> None:
        """Start the service on its own loop thread (the process entry point does this)."""
        self._background = BackgroundLoop()
        self._background.run(self.perception.start())

    def close(self) -> None:
        if self._background is not None:
            self._background.run(self.perception.close())
            self._background.stop()
            self._background = None
        if self.bridge is not None:
            self.bridge.close()


def event_sink(config: PerceptionConfig) -> EventSink:
    if config.events_url and config.event_secret is not None:
        return PosterEventSink(
            config.events_url,
            config.event_secret.get_secret_value(),
            config.outbox_path,
            SERVER_NAME,
        )
    return LoggingEventSink()


def build_app(
    config: PerceptionConfig,
    *,
    bridge: RosBridge | None = None,
    vision_tasks: VisionTasks | None = None,
    sink: EventSink | None = None,
    follow_topics: bool = True,
) -> PerceptionApp:
    """Wire buffer, ROS follower, watchers and the MCP server.

    ``vision_tasks`` / ``sink`` replace the ROS and HTTP adapters in tests;
    ``follow_topics=False`` builds no ROS subscriptions (pure buffer tests).
    """
    buffer = RollingBuffer(config.max_count, config.max_age_s)
    if bridge is None and (vision_tasks is None or follow_topics):
        bridge = RosBridge(config.ros_node_name)
    if bridge is not None:
        bridge.start()
    if vision_tasks is None:
        assert bridge is not None
        vision_tasks = RosVisionTasks(
            bridge,
            config.vision_node_name,
            timeout_s=config.call_timeout_s,
            wait_for_service_s=config.wait_for_service_s,
        )
    follower = (
        TopicFollower(bridge, buffer, gone_grace_s=config.gone_grace_s)
        if follow_topics and bridge is not None
        else None
    )
    watchers = WatcherService(buffer, sink or event_sink(config), SERVER_NAME)
    perception = Perception(config, buffer, watchers, vision_tasks, follower)
    return PerceptionApp(config, build_server(perception), perception, buffer, bridge)


def run() -> None:
    """The process: over stdio, stdout is reserved for JSON-RPC before ROS starts (rcl and
    Fast DDS output goes to stderr); a bad configuration exits 2 with one line."""
    try:
        settings = transport_settings(os.environ, DEFAULT_PORT)
        config = PerceptionConfig.from_env()
    except ValueError as error:
        refuse_to_start(SERVICE, error)
    wire = reserve_stdout() if settings.transport == "stdio" else None
    configure_logging(SERVICE, level=config.log_level)
    app = build_app(config)
    try:
        app.start_background()
    except OutboxError as error:
        app.close()
        refuse_to_start(SERVICE, error)
    try:
        run_server(app.server, DEFAULT_PORT, wire)
    finally:
        app.close()


def main() -> None:
    """Console script ``mcp-perception-buffer``: stdio by default, sse / streamable-http by env."""
    run()
