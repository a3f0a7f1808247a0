"""The MCP surface of the manipulation server: thin tools over the Manipulator."""

from __future__ import annotations

from typing import Any

from mcp.server.mcpserver import MCPServer
from pydantic import BaseModel, ConfigDict, Field

from robot_mcp_kit.annotations import MOVES_ROBOT, READ_ONLY
from robot_mcp_kit.motion_tools import LogLevel, add_stop_tool, add_task_tools, guard, motion_server
from robot_mcp_kit.supervision import Supervision
from robot_mcp_manipulation.arm.port import DetectionTarget
from robot_mcp_manipulation.manipulator import Manipulator

SERVER_NAME = "manipulation"

INSTRUCTIONS = """\
The robot's arm and gripper. pick and place are asynchronous: they return a TaskInfo
({task_id, state: "running", est_duration_s, ...}) at once, then the server pushes progress,
task_done or task_failed events for that task_id. pick takes the mask_ref of a detection the
perception server returned (find_object): the arm reads the mask from the robot itself. One
motion at a time; stop_manipulation stops the arm immediately. After a pick or place, call
get_held to read back what the robot holds."""


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


def build_mcp_server(
    manipulator: Manipulator,
    log_level: LogLevel = "INFO",
    max_age_s: float = 0.0,
    supervision: Supervision | None = None,
) -> MCPServer:
    server = motion_server(SERVER_NAME, INSTRUCTIONS, log_level, supervision)

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
        info = await guard(manipulator.pick(target, max_age_s))
        return info.model_dump(mode="json")

    @server.tool(annotations=MOVES_ROBOT)
    async def place() -> dict[str, Any]:
        """Put what the robot holds down on the surface in front of it, where it stands now.

        Returns at once with a TaskInfo; task_done carries placed_label and what is held
        after; task_failed: NOTHING_HELD, NO_SURFACE, PLACE_FAILED, ARM_NOT_READY, ...
        """
        info = await guard(manipulator.place("place"))
        return info.model_dump(mode="json")

    @server.tool(annotations=MOVES_ROBOT)
    async def release() -> dict[str, Any]:
        """Open the gripper where the arm is, without placing (hand it over to a person who
        holds it, or drop it). Asynchronous like place."""
        info = await guard(manipulator.place("release"))
        return info.model_dump(mode="json")

    @server.tool(annotations=READ_ONLY)
    async def get_held() -> dict[str, Any]:
        """What the robot's gripper holds now, as the robot reports it: {known, holding,
        label, since, busy, task_id, action}. known is false until the robot reported."""
        return manipulator.held()

    add_stop_tool(
        server,
        "stop_manipulation",
        "Stop the arm immediately: cancel the running pick or place, if any.\n\nSafe to call "
        'at any time. Returns the cancelled task (state "cancelled") or null, and what the '
        "gripper holds now.",
        manipulator.stop,
        lambda: {"held": manipulator.held()},
    )
    add_task_tools(server, manipulator, "pick/place", "the arm stops")
    return server
