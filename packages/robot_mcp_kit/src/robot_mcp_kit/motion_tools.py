"""The MCP tools every motion server serves the same way over its ``MotionTasks``: the server
itself (tool errors as JSON, the brain's ``supervise`` tool), the stop tool (never gated),
``get_task``, ``cancel_task``, ``list_tasks``, and the guard that turns a domain's
``MotionError`` into a tool error the planner reads (``{"error", "detail"}``)."""

from __future__ import annotations

from collections.abc import Awaitable, Callable, Iterable
from typing import Any, Literal, Protocol, TypeVar

from mcp.server.mcpserver import MCPServer

from robot_mcp_kit.annotations import READ_ONLY, STOPS
from robot_mcp_kit.mcp_runtime import install_json_tool_errors, tool_error
from robot_mcp_kit.models import TaskInfo, TaskState
from robot_mcp_kit.motion_errors import MotionError
from robot_mcp_kit.supervision import Supervision
from robot_mcp_kit.supervision_tools import add_supervise_tool

T = TypeVar("T")
LogLevel = Literal["DEBUG", "INFO", "WARNING", "ERROR"]


class TaskService(Protocol):
    def get_task(self, task_id: str) -> TaskInfo: ...

    async def cancel_task(self, task_id: str) -> TaskInfo: ...

    def list_tasks(self, states: Iterable[TaskState] | None = None) -> list[TaskInfo]: ...


def motion_server(
    name: str,
    instructions: str | None = None,
    log_level: LogLevel = "INFO",
    supervision: Supervision | None = None,
) -> MCPServer:
    """A motion server's MCPServer: tool errors reach the planner as ``{"error", "detail"}``;
    with ``supervision``, the brain's ``supervise`` tool renews its lease (issue 27)."""
    server = MCPServer(name, instructions=instructions, log_level=log_level)
    install_json_tool_errors(server)
    if supervision is not None:
        add_supervise_tool(server, supervision)
    return server


async def guard(call: Awaitable[T]) -> T:
    """Turn domain errors into tool errors the planner can read."""
    try:
        return await call
    except MotionError as exc:
        raise tool_error(exc.code, exc.detail) from exc


def add_stop_tool(
    server: MCPServer,
    name: str,
    description: str,
    stop: Callable[[], Awaitable[TaskInfo | None]],
    after: Callable[[], dict[str, Any]],
) -> None:
    """The stop tool ``name``: ``stop()``, then ``{"stopped": true, "cancelled_task", ...}``
    with what ``after()`` says of the robot once stopped (its pose, what it holds)."""

    @server.tool(name=name, description=description, annotations=STOPS)
    async def stop_motion() -> dict[str, Any]:
        final = await stop()
        return {
            "stopped": True,
            "cancelled_task": final.model_dump(mode="json") if final else None,
            **after(),
        }


def add_task_tools(server: MCPServer, service: TaskService, what: str, halts: str) -> None:
    """``get_task``, ``cancel_task`` and ``list_tasks`` over ``service``; ``what`` names its
    tasks ("navigation", "pick/place"), ``halts`` what a cancel does to the robot."""

    @server.tool(
        annotations=READ_ONLY,
        description=f"The current TaskInfo of a {what} task: state (running, succeeded, "
        "failed, cancelled), live progress while running, result or error when finished.",
    )
    async def get_task(task_id: str) -> dict[str, Any]:
        try:
            info = service.get_task(task_id)
        except MotionError as exc:
            raise tool_error(exc.code, exc.detail) from exc
        return info.model_dump(mode="json")

    @server.tool(
        annotations=STOPS,
        description=f"Cancel a {what} task: {halts} and the task ends as cancelled. A task "
        "that already ended is returned unchanged.",
    )
    async def cancel_task(task_id: str) -> dict[str, Any]:
        info = await guard(service.cancel_task(task_id))
        return info.model_dump(mode="json")

    @server.tool(
        annotations=READ_ONLY,
        description=f"{what[:1].upper()}{what[1:]} tasks known to this server (since it "
        'started), optionally filtered by state, e.g. states=["running"] to reconcile after '
        "a restart.",
    )
    async def list_tasks(states: list[TaskState] | None = None) -> dict[str, Any]:
        tasks = service.list_tasks(states)
        return {"tasks": [t.model_dump(mode="json") for t in tasks]}
