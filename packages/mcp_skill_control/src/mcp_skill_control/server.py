"""The ``skill_control`` MCP server: tool definitions (docstrings written for the planner) and
the console entry point ``mcp-skill-control``.

Every tool returns a JSON object as MCP structured content (``structuredContent``, with an
object output schema; the text block carries the same JSON for clients that read text).
Failures are clean tool errors whose text is JSON ``{"error": "<code>", "detail": "<sentence>"}``
(the vision node's own code when it refused).
"""

from __future__ import annotations

from collections.abc import Awaitable, Callable
from typing import Any

import structlog
from mcp.server.mcpserver import MCPServer

from mcp_skill_control.catalog import CatalogError
from mcp_skill_control.params import ParamValue
from mcp_skill_control.tools import SkillControl
from robot_mcp_kit.annotations import CONFIGURES_FREELY, READ_ONLY, RECORDS, STOPS
from robot_mcp_kit.mcp_runtime import install_json_tool_errors, tool_error
from robot_ros_bridge import RosBridgeError

logger = structlog.get_logger(__name__)
SERVER_NAME = "skill_control"

INSTRUCTIONS = (
    "Configure what the robot's camera pipeline computes. list_skill_templates shows what "
    "can be instantiated; instantiate_skill starts a skill and returns the ROS topic its "
    "results appear on; read results with the perception server (get_latest / "
    "wait_for_result), never here. Stop skills you no longer need with stop_skill."
)


async def _guard(name: str, call: Callable[[], Awaitable[dict[str, Any]]]) -> dict[str, Any]:
    """Run a tool body; map domain / ROS failures to a clean tool error."""
    try:
        return await call()
    except CatalogError as error:
        raise tool_error(error.code, error.detail) from error
    except RosBridgeError as error:
        logger.warning("tool_failed", tool=name, error=error.code, detail=error.detail)
        raise tool_error(error.code, error.detail) from error


def build_server(control: SkillControl) -> MCPServer:
    server: MCPServer = MCPServer(SERVER_NAME, instructions=INSTRUCTIONS)

    @server.tool(annotations=READ_ONLY)
    async def list_skill_templates() -> dict[str, Any]:
        """List the skill templates the robot can be configured with.

        Call this first when you need the robot to look for, segment, locate or watch
        something, to learn which templates exist and which params each one needs.
        Returns {"templates": [{"name", "description", "params", "param_types", "watcher",
        "mode"}]}; param_types says whether each param is a string, number, integer or boolean.
        """
        return await _guard("list_skill_templates", _sync(control.templates))

    @server.tool(annotations=READ_ONLY)
    async def list_running_skills() -> dict[str, Any]:
        """List the skills currently running on the vision node.

        Call this before instantiating a skill (one may already publish what you need) and to
        find a skill_id to stop. Returns {"skills": [{"skill_id", "name", "topic",
        "semantic_topics", "enabled", "mode", "once", "template"?, "task_id"?}]}.
        """
        return await _guard("list_running_skills", control.running_skills)

    @server.tool(annotations=RECORDS)
    async def instantiate_skill(
        template: str, params: dict[str, ParamValue] | None = None
    ) -> dict[str, Any]:
        """Start a skill from a catalog template on the robot's camera pipeline.

        Call this when you need fresh perception: e.g. template "find_object" with params
        {"query": "scissors on top of the pile"}, "describe_scene" with {}, "free_space" with
        {"what": "package"}, or "watch_for" with {"condition": "the door is open"}.
        Returns {"skill_id", "topic", "meta_topic", "semantic_topics", "mode", "once"}; then
        call perception.wait_for_result(skill_id) or perception.get_latest(skill_id) to read
        the result (labels, boxes, scores, mask references; never pixels). A watcher template
        also returns {"task_id": "watch-<skill_id>", "state": "running"}: you will receive a
        watch_event when the condition becomes true. Stop the skill with stop_skill when done.
        """
        return await _guard(
            "instantiate_skill", lambda: control.instantiate(template, dict(params or {}))
        )

    @server.tool(annotations=CONFIGURES_FREELY)
    async def instantiate_raw_skill(skill: dict[str, Any]) -> dict[str, Any]:
        """Start an ad-hoc skill that is not in the catalog (escape hatch).

        Call this only when no template fits. `skill` is a full vision skill object:
        {"name", "mode": "describe"|"ground_and_segment"|"segment_all"|"region",
        "grounding", "segment", "outputs": [{"name", "type", "description"}], "rate_hz",
        "once", "watch": {"output", "equals"}}. Returns the same shape as instantiate_skill.
        """
        return await _guard("instantiate_raw_skill", lambda: control.instantiate_raw(skill))

    @server.tool(annotations=RECORDS)
    async def prewarm_skill(
        template: str, params: dict[str, ParamValue] | None = None
    ) -> dict[str, Any]:
        """Pre-compute a template's grounding so a later instantiate_skill answers faster.

        Call this when you expect to need a grounding skill shortly (e.g. while the robot
        drives to the table, prewarm find_object {"query": "red mug"}). Publishes nothing;
        returns {"skill_id", "prewarm": true, "grounding"}. Only grounding templates qualify.
        """
        return await _guard("prewarm_skill", lambda: control.prewarm(template, dict(params or {})))

    @server.tool(annotations=STOPS)
    async def stop_skill(skill_id: str) -> dict[str, Any]:
        """Stop a running skill and remove its topics.

        Call this when you no longer need a skill's results (after a one-shot find, when a
        watcher has fired, or before the task ends). Returns {"skill_id", "stopped": true}.
        """
        return await _guard("stop_skill", lambda: control.stop(skill_id))

    @server.tool(annotations=STOPS)
    async def set_skill_enabled(skill_id: str, enabled: bool) -> dict[str, Any]:
        """Pause (enabled=false) or resume (enabled=true) a skill without losing its config.

        Call this to save compute while a standing skill is temporarily not needed.
        Returns {"skill_id", "enabled"}.
        """
        return await _guard("set_skill_enabled", lambda: control.set_enabled(skill_id, enabled))

    return install_json_tool_errors(server)


def _sync(fn: Callable[[], dict[str, Any]]) -> Callable[[], Awaitable[dict[str, Any]]]:
    async def call() -> dict[str, Any]:
        return fn()

    return call
