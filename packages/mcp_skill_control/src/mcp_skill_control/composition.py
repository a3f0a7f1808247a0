"""The composition root of the ``mcp-skill-control`` process: the only place adapters are built."""

from __future__ import annotations

import os
from dataclasses import dataclass

from mcp.server.mcpserver import MCPServer

from mcp_skill_control.catalog import Catalog, CatalogError
from mcp_skill_control.config import DEFAULT_PORT, SkillControlConfig
from mcp_skill_control.reconcile import CreateReconciler
from mcp_skill_control.server import build_server
from mcp_skill_control.tools import SkillControl
from robot_mcp_kit.logging import configure_logging
from robot_mcp_kit.mcp_runtime import reserve_stdout, run_server, transport_settings
from robot_mcp_kit.startup import refuse_to_start
from robot_ros_bridge import RosBridge
from robot_ros_bridge.vision_tasks import RosVisionTasks, VisionTasks

SERVICE = "mcp-skill-control"


@dataclass
class SkillControlApp:
    config: SkillControlConfig
    server: MCPServer
    control: SkillControl
    bridge: RosBridge | None


def build_app(
    config: SkillControlConfig,
    *,
    bridge: RosBridge | None = None,
    tasks: VisionTasks | None = None,
) -> SkillControlApp:
    """Wire the catalog, the VisionTask adapter and the MCP server.

    ``tasks`` replaces the ROS adapter (tests); otherwise ``bridge`` (started by the caller)
    carries the VisionTask clients.
    """
    catalog = Catalog.load(config.skills_catalog)
    if tasks is None:
        if bridge is None:
            bridge = RosBridge(config.ros_node_name)
        tasks = RosVisionTasks(
            bridge.start(),
            config.vision_node_name,
            timeout_s=config.call_timeout_s,
            wait_for_service_s=config.wait_for_service_s,
        )
    reconciler = CreateReconciler(
        tasks, confirm_s=config.reconcile_s, sweep_s=config.orphan_sweep_s
    )
    control = SkillControl(catalog, tasks, reconciler)
    return SkillControlApp(config, build_server(control), control, bridge)


def run() -> None:
    """The process: over stdio, stdout is reserved for JSON-RPC before ROS starts (rcl and
    Fast DDS output goes to stderr); a bad configuration exits 2 with one line."""
    try:
        settings = transport_settings(os.environ, DEFAULT_PORT)
        config = SkillControlConfig.from_env()
    except ValueError as error:
        refuse_to_start(SERVICE, error)
    wire = reserve_stdout() if settings.transport == "stdio" else None
    configure_logging(SERVICE, level=config.log_level)
    try:
        app = build_app(config)
    except CatalogError as error:
        refuse_to_start(SERVICE, error)
    try:
        run_server(app.server, DEFAULT_PORT, wire)
    finally:
        if app.bridge is not None:
            app.bridge.close()


def main() -> None:
    """Console script ``mcp-skill-control``: stdio by default, sse / streamable-http by env."""
    run()
