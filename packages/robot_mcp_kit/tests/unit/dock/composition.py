"""Step 5 of the recipe: the composition root and the console script — the kit runs the
process (``MotionWiring.run_motion``, ``run_motion_server``); a real server opens its ROS side
here (``robot_ros_bridge.motion_side.open_motion_side``) and hands it over as a ``MotionSide``."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Literal

from mcp.server.mcpserver import MCPServer

from robot_mcp_kit.motion_serving import MotionWiring, run_motion_server
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
class DockApp(MotionWiring):
    settings: DockSettings
    dock: FakeDock
    docker: Docker
    server: MCPServer


def build_app(settings: DockSettings, supervision: Supervision | None = None) -> DockApp:
    supervision = supervision or Supervision(required=True)
    dock, events = FakeDock(), FakeEventSink()
    docker = Docker(dock, events, TaskTable("dock"), gate=supervision)
    server = build_mcp_server(docker, supervision)
    return DockApp(
        settings,
        dock,
        docker,
        server,
        name="docking",
        service=docker.motion,
        events=events,
        supervision=supervision,
        ready={"dock": "fake"},
    )


def load_settings(environ: Mapping[str, str]) -> DockSettings:
    if environ.get("DOCK_BROKEN"):
        raise ConfigError("DOCK_BROKEN is set")
    return DockSettings()


def main() -> None:
    run_motion_server("docking", load_settings, build_app, (ConfigError,))
