"""The ``perception`` MCP server (the brain's eyes): tool definitions written for the planner
and the console entry point ``mcp-perception-buffer``.

Every tool returns a JSON object as MCP structured content (``structuredContent``; the text
block carries the same JSON) with ``stamp`` (source image time, unix s), ``age_s`` and
``stale``. Detections carry label, score, kind, box, point and a ``mask_ref`` — never pixels.
Failures are tool errors whose text is JSON ``{"error": "<code>", "detail": "<sentence>"}``.
"""

from __future__ import annotations

import json
from collections.abc import Awaitable, Callable
from typing import Any, Literal

import structlog
from mcp.server.mcpserver import MCPServer

from mcp_perception_buffer.config import SERVER_NAME
from mcp_perception_buffer.service import Perception, PerceptionError
from robot_mcp_kit.annotations import READ_ONLY, STOPS
from robot_mcp_kit.mcp_runtime import install_json_tool_errors, tool_error
from robot_ros_bridge import RosBridgeError

logger = structlog.get_logger(__name__)

INSTRUCTIONS = (
    "Read what the robot's camera pipeline has produced. what_do_you_see gives the current "
    "scene if some skill is warm and says how to get a fresh view if not; get_latest / "
    "wait_for_result read one skill's results (start skills with skill_control). Results "
    "carry stamp, age_s and stale; masks are referenced (mask_ref), never sent."
)

StateName = Literal["running", "succeeded", "failed", "cancelled"]


async def _guard(name: str, call: Callable[[], Awaitable[dict[str, Any]]]) -> dict[str, Any]:
    try:
        return _jsonable(await call())
    except PerceptionError as error:
        raise tool_error(error.code, error.detail) from error
    except RosBridgeError as error:
        logger.warning("tool_failed", tool=name, error=error.code, detail=error.detail)
        raise tool_error(error.code, error.detail) from error


def _jsonable(answer: dict[str, Any]) -> dict[str, Any]:
    """Plain JSON types only (values read from topics may be anything JSON decodes to)."""
    decoded: dict[str, Any] = json.loads(json.dumps(answer, default=str))
    return decoded


def _now(fn: Callable[[], dict[str, Any]]) -> Callable[[], Awaitable[dict[str, Any]]]:
    async def call() -> dict[str, Any]:
        return fn()

    return call


def build_server(perception: Perception) -> MCPServer:
    server: MCPServer = MCPServer(SERVER_NAME, instructions=INSTRUCTIONS)

    @server.tool(annotations=READ_ONLY)
    async def what_do_you_see() -> dict[str, Any]:
        """Answer "what do you see?" from what is already buffered (free, instant).

        Call this first whenever you need to know what is in front of the robot. Returns
        {"mode": "warm"|"stale"|"cold", "stamp", "age_s", "stale", "scene_description",
        "scene_objects", "skills": [latest detections per skill], "hint"}. If mode is "cold"
        or "stale", follow "hint": instantiate describe_scene with skill_control and call
        wait_for_result for a fresh view (one model call); ask memory for the past.
        """
        return await _guard("what_do_you_see", _now(perception.what_do_you_see))

    @server.tool(annotations=READ_ONLY)
    async def get_latest(skill: str) -> dict[str, Any]:
        """Return the newest result of one running skill (non-blocking).

        Call this to read a standing skill's current answer; `skill` is the skill_id that
        skill_control.instantiate_skill returned. Returns {"skill", "stamp", "age_s", "stale",
        "detections": [{"label", "score", "kind", "box", "point", "mask_ref"}], "outputs":
        {name: {"value", "stamp", "age_s", "stale"}}}. Check "stale" before acting on it.
        """
        return await _guard("get_latest", _now(lambda: perception.get_latest(skill)))

    @server.tool(annotations=READ_ONLY)
    async def get_history(skill: str, seconds: float = 30.0) -> dict[str, Any]:
        """Return a skill's buffered results of the last `seconds` seconds, oldest first.

        Call this to see how something changed (did the object move, when did the door
        open). Returns {"skill", "seconds", "stamp", "age_s", "stale", "results": [...],
        "outputs": {name: [...]}}. The buffer keeps a bounded window; older data is gone.
        """
        return await _guard("get_history", _now(lambda: perception.get_history(skill, seconds)))

    @server.tool(annotations=READ_ONLY)
    async def wait_for_result(
        skill: str, timeout_s: float = 15.0, after_stamp: float | None = None
    ) -> dict[str, Any]:
        """Block until `skill` has a result, then return it (same shape as get_latest).

        Call this right after skill_control.instantiate_skill for a one-shot skill (e.g.
        find_object, describe_scene). Pass `after_stamp` (a previous result's stamp) to wait
        for a newer one. Gives up with a "timeout" error after `timeout_s` (max 25 s).
        """
        return await _guard(
            "wait_for_result",
            lambda: perception.wait_for_result(skill, timeout_s, after_stamp),
        )

    @server.tool(annotations=READ_ONLY)
    async def list_buffers() -> dict[str, Any]:
        """List every skill the buffer follows, with counts and freshness.

        Call this to see which skills currently publish and how fresh each is. Returns
        {"stamp", "age_s", "stale", "buffers": [{"skill", "topics", "results", "outputs",
        "stamp", "age_s", "stale"}], "following"}.
        """
        return await _guard("list_buffers", _now(perception.list_buffers))

    @server.tool(annotations=READ_ONLY)
    async def get_health() -> dict[str, Any]:
        """Report whether this server's watch events reach the brain.

        Call this when a watcher fired but no event arrived, or to check the server. Returns
        {"status": "ok"|"degraded", "events": {"status": "ok"|"refused"|"not_posting",
        "last_refusal", "pending", "dead_letters", ...}, "watchers_running", "following"}.
        "refused" means the brain refuses our events (secret or clock): they wait in the
        outbox and are delivered once that is fixed.
        """
        return await _guard("get_health", perception.health)

    @server.tool(annotations=READ_ONLY)
    async def get_task(task_id: str) -> dict[str, Any]:
        """Return the state of a watcher task ("watch-<skill_id>").

        Call this to check whether a watcher is still armed and how often and when it fired.
        Returns a TaskInfo {"task_id", "state", "skill", "output", "equals", "started_at",
        "fired", "fired_at": [unix s, most recent last], "last_fired_at", and once ended
        "finished_at" and "reason" ("cancelled_by_caller" | "skill_stopped")}.
        """
        return await _guard("get_task", lambda: perception.get_task(task_id))

    @server.tool(annotations=STOPS)
    async def cancel_task(task_id: str, stop_skill: bool = True) -> dict[str, Any]:
        """End a watcher task: disarm it (no more watch_events) and stop its skill.

        Call this when the watched condition no longer matters (the mission finished or was
        aborted). A final task_failed event (error_code CANCELLED, state "cancelled") is
        posted. Pass `stop_skill=false` only to keep the skill publishing without the
        watcher. Returns the finished TaskInfo plus "skill_stopped" (and "skill_stop_error"
        if it could not be).
        """
        return await _guard("cancel_task", lambda: perception.cancel_task(task_id, stop_skill))

    @server.tool(annotations=READ_ONLY)
    async def list_tasks(states: list[StateName] | None = None) -> dict[str, Any]:
        """List watcher tasks, optionally only those in `states` (e.g. ["running"]).

        Call this to see which watchers are armed. Returns {"tasks": [TaskInfo...]}.
        """
        return await _guard(
            "list_tasks", lambda: perception.list_tasks(list(states) if states else None)
        )

    return install_json_tool_errors(server)
