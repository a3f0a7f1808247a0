"""Step 5 of the recipe: the composition root and the console script — the kit runs the
process (``motion_running``, ``run_motion_server``); a real server would open its ROS side here
with ``robot_ros_bridge.motion_side.open_motion_side`` and add its closer."""

from __future__ import annotations

from collections.abc import AsyncIterator, Callable, Mapping
from contextlib import asynccontextmanager
from dataclasses import dataclass, field
from typing import Literal

from mcp.server.mcpserver import MCPServer

from robot_mcp_kit.motion_serving import motion_running, run_motion_server
from robot_mcp_kit.supervision import Supervision
from robot_mcp_kit.task_events.fake import FakeEventSink
from robot_mcp_kit.tasks import TaskTable

from .docking import Docker
from .port import FakeDock
from .tools import build_mcp_server


class ConfigError(ValueError):
    pass


@dataclass(frozen=True)
class DockSettings:
    transport: Literal["stdio", "sse", "streamable-http"] = "stdio"
    host: str = "127.0.0.1"
    port: int = 9109
    log_level: str = "INFO"


@dataclass
class DockApp:
    settings: DockSettings
    dock: FakeDock
    events: FakeEventSink
    docker: Docker
    server: MCPServer
    supervision: Supervision
    closers: list[Callable[[], None]] = field(default_factory=list)

    @asynccontextmanager
    async def running(self) -> AsyncIterator[DockApp]:
        async with motion_running(
            "docking",
            self.events,
            self.docker.motion,
            supervision=self.supervision,
            closers=self.closers,
            ready={"dock": "fake"},
        ):
            yield self


def build_app(settings: DockSettings, supervision: Supervision | None = None) -> DockApp:
    supervision = supervision or Supervision(required=True)
    dock, events = FakeDock(), FakeEventSink()
    docker = Docker(dock, events, TaskTable("dock"), gate=supervision)
    server = build_mcp_server(docker, supervision)
    return DockApp(settings, dock, events, docker, server, supervision)


def load_settings(environ: Mapping[str, str]) -> DockSettings:
    if environ.get("DOCK_BROKEN"):
        raise ConfigError("DOCK_BROKEN is set")
    return DockSettings()


def main() -> None:
    run_motion_server("docking", load_settings, build_app, (ConfigError,))
