"""The MCP surface of the manipulation server: thin tools over the Manipulator."""

from __future__ import annotations

from collections.abc import Awaitable
from typing import Any, Literal, TypeVar

from mcp.server.mcpserver import MCPServer
from pydantic import BaseModel, ConfigDict, Field

from robot_mcp_kit.annotations import MOVES_ROBOT, READ_ONLY, STOPS
from robot_mcp_kit.mcp_runtime import install_json_tool_errors, tool_error
from robot_mcp_kit.models import TaskState
from robot_mcp_kit.supervision import Supervision
from robot_mcp_kit.supervision_tools import add_supervise_tool
from robot_mcp_manipulation.arm.port import DetectionTarget
from robot_mcp_manipulation.errors import ManipulationError
from robot_mcp_manipulation.manipulator import Manipulator

SERVER_NAME = "manipulation"

INSTRUCTIONS = """\
The robot's arm and gripper. pick and place are asynchronous: they return a TaskInfo
({task_id, state: "running", est_duration_s, ...}) at once, then the server pushes progress,
task_done or task_failed events for that task_id. pick takes the mask_ref of a detection the
perception server returned (find_object): the arm reads the mask from the robot itself. One
motion at a time; stop_manipulation stops the arm immediately. After a pick or place, call
get_held to read back what the robot holds."""

T = TypeVar("T")
LogLevel = Literal["DEBUG", "INFO", "WARNING", "ERROR"]


class MaskRef(BaseModel):
    """A detection's reference as the perception server returns it (``mask_ref``)."""

    model_config = ConfigDict(extra="ignore")

    topic: str = Field(
        pattern=r"^/vision/[A-Za-z0-9_]+/detections$",
        description="the skill's detections topic, e.g. /vision/find_object/detections",
    )
    stamp: float = Field(gt=0, description="the detection result's stamp (unix seconds)")
    index: int = Field(default=-1, ge=-1, description="the detection's index; -1: best by label")
    url: str | None = Field(default=None, description="ignored: the arm reads masks from ROS")


async def _guard(call: Awaitable[T]) -> T:
    """Turn domain errors into tool errors the planner can read."""
    try:
        return await call
    except ManipulationError as exc:
        raise tool_error(exc.code, exc.detail) from exc


def build_mcp_server(
    manipulator: Manipulator,
    log_level: LogLevel = "INFO",
    max_age_s: float = 0.0,
    supervision: Supervision | None = None,
) -> MCPServer:
    server = MCPServer(SERVER_NAME, instructions=INSTRUCTIONS, log_level=log_level)
    install_json_tool_errors(server)  # tool errors reach the planner as {"error", "detail"}
    if supervision is not None:
        add_supervise_tool(server, supervision)  # the brain's lease (issue 27)

    @server.tool(annotations=MOVES_ROBOT)
    async def pick(label: str, mask_ref: MaskRef) -> dict[str, Any]:
        """Pick up an object the camera has just found: the arm grasps it and lifts it.

        label: what it is ("yellow package"); mask_ref: the detection's mask_ref exactly as
        perception.wait_for_result / get_latest returned it ({topic, stamp, index, url}). The
        robot must stand where the object is. Returns at once with a TaskInfo; the outcome
        arrives as task_done (with what is held) or task_failed (error_code NOT_VISIBLE,
        DETECTION_STALE, OUT_OF_REACH, GRASP_FAILED, ALREADY_HOLDING, ARM_NOT_READY, ... with
        recoverable and suggestions). Refused with MANIPULATION_BUSY while the arm is busy.
        """
        target = DetectionTarget(mask_ref.topic, mask_ref.stamp, mask_ref.index, label.strip())
        info = await _guard(manipulator.pick(target, max_age_s))
        return info.model_dump(mode="json")

    @server.tool(annotations=MOVES_ROBOT)
    async def place() -> dict[str, Any]:
        """Put what the robot holds down on the surface in front of it, where it stands now.

        Returns at once with a TaskInfo; task_done carries placed_label and what is held
        after; task_failed: NOTHING_HELD, NO_SURFACE, PLACE_FAILED, ARM_NOT_READY, ...
        """
        info = await _guard(manipulator.place("place"))
        return info.model_dump(mode="json")

    @server.tool(annotations=MOVES_ROBOT)
    async def release() -> dict[str, Any]:
        """Open the gripper where the arm is, without placing (hand it over to a person who
        holds it, or drop it). Asynchronous like place."""
        info = await _guard(manipulator.place("release"))
        return info.model_dump(mode="json")

    @server.tool(annotations=READ_ONLY)
    async def get_held() -> dict[str, Any]:
        """What the robot's gripper holds now, as the robot reports it: {known, holding,
        label, since, busy, task_id, action}. known is false until the robot reported."""
        return manipulator.held()

    @server.tool(annotations=STOPS)
    async def stop_manipulation() -> dict[str, Any]:
        """Stop the arm immediately: cancel the running pick or place, if any.

        Safe to call at any time. Returns the cancelled task (state "cancelled") or null,
        and what the gripper holds now."""
        final = await manipulator.stop()
        return {
            "stopped": True,
            "cancelled_task": final.model_dump(mode="json") if final else None,
            "held": manipulator.held(),
        }

    @server.tool(annotations=READ_ONLY)
    async def get_task(task_id: str) -> dict[str, Any]:
        """The current TaskInfo of a pick/place task: state (running, succeeded, failed,
        cancelled), live progress while running, result or error when finished."""
        try:
            info = manipulator.get_task(task_id)
        except ManipulationError as exc:
            raise tool_error(exc.code, exc.detail) from exc
        return info.model_dump(mode="json")

    @server.tool(annotations=STOPS)
    async def cancel_task(task_id: str) -> dict[str, Any]:
        """Cancel a pick/place task: the arm stops and the task ends as cancelled. A task
        that already ended is returned unchanged."""
        info = await _guard(manipulator.cancel_task(task_id))
        return info.model_dump(mode="json")

    @server.tool(annotations=READ_ONLY)
    async def list_tasks(states: list[TaskState] | None = None) -> dict[str, Any]:
        """Pick/place tasks known to this server (since it started), optionally filtered by
        state, e.g. states=["running"] to reconcile after a restart."""
        tasks = manipulator.list_tasks(states)
        return {"tasks": [t.model_dump(mode="json") for t in tasks]}

    return server
