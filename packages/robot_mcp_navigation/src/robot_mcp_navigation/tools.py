"""The MCP surface of the navigation server: thin tools over the Navigator."""

from __future__ import annotations

from typing import Any

from mcp.server.mcpserver import Context, MCPServer

from robot_mcp_kit.annotations import MOVES_ROBOT, READ_ONLY
from robot_mcp_kit.motion_tools import LogLevel, add_stop_tool, add_task_tools, guard, motion_server
from robot_mcp_navigation.confirmation import MotionConfirmer
from robot_mcp_navigation.mapview.base import MapView, NoMapView
from robot_mcp_navigation.mapview.render import floor_view, plan_points
from robot_mcp_navigation.navigator import Navigator
from robot_mcp_navigation.triggers import Trigger

SERVER_NAME = "navigation"

INSTRUCTIONS = """\
Drives the robot base between named locations of the map. navigate_to is asynchronous: it
returns a TaskInfo ({task_id, state: "running", est_duration_s, ...}) at once, then the
server pushes progress, trigger_fired, task_done or task_failed events for that task_id.
Only one navigation runs at a time; stop_navigation halts the robot immediately.
Durations are robot seconds."""


async def _refused_now(navigator: Navigator) -> None:
    navigator.refuse_unsupervised()


def build_mcp_server(
    navigator: Navigator,
    log_level: LogLevel = "INFO",
    confirmer: MotionConfirmer | None = None,
    map_view: MapView | None = None,
) -> MCPServer:
    """``confirmer``: ask the client's person before each drive (NAV_CONFIRM_MOTION=elicit);
    ``map_view``: the robot's map, costmap and plan (Nav2's topics)."""
    view = map_view or NoMapView()
    server = motion_server(SERVER_NAME, INSTRUCTIONS, log_level, navigator.supervision)

    @server.tool(annotations=MOVES_ROBOT)
    async def navigate_to(
        location: str, ctx: Context, triggers: list[Trigger] | None = None
    ) -> dict[str, Any]:
        """Start driving the robot to a named location (see list_locations).

        Returns at once with a TaskInfo: {"task_id", "state": "running", "est_duration_s",
        "destination", ...}. The outcome arrives later as a task_done or task_failed event
        for that task_id (task_failed carries error_code, message, recoverable and
        suggestions, e.g. DOOR_CLOSED). Optional triggers each fire once as a trigger_fired
        event: {"type": "eta_below", "seconds": 10} fires when the ETA drops below 10 s,
        {"type": "distance_below", "meters": 2} when less than 2 m remain — use them to
        prepare the next step before arrival. Refused with NAVIGATION_BUSY while another
        navigation runs: call stop_navigation or cancel_task first; with SAFETY_STOP_LATCHED
        while the software stop is latched, NOT_SUPERVISED while no supervising brain holds
        this server's lease.
        """
        if confirmer is not None:
            await guard(_refused_now(navigator))  # never ask a person about a refused drive
            await confirmer.confirm(ctx, location)
        info = await guard(navigator.navigate_to(location, triggers or []))
        return info.model_dump(mode="json")

    add_stop_tool(
        server,
        "stop_navigation",
        "Halt the robot immediately and cancel the running navigation, if any.\n\nSafe to "
        "call at any time (also when not moving). Returns the pose where the robot stopped "
        'and the cancelled task (state "cancelled"), or null if none was running.',
        navigator.stop,
        lambda: {"pose": navigator.pose()},
    )

    @server.tool(annotations=READ_ONLY)
    async def get_pose() -> dict[str, Any]:
        """Where the robot is: x, y, theta (map frame), the named location it is at (or
        null), whether it is moving and towards which destination; stale (with pose_note)
        when no live pose comes from the base, relocated when it came back elsewhere."""
        return navigator.pose()

    @server.tool(annotations=READ_ONLY)
    async def list_locations() -> dict[str, Any]:
        """The named locations of the map, with description, aliases, distance from the
        robot and estimated driving time in seconds."""
        return navigator.locations()

    @server.tool(annotations=READ_ONLY)
    async def get_map() -> dict[str, Any]:
        """The robot's own map, for a display (missions need list_locations, not this):
        walls and unmapped area as small PNG masks (base64, top row = largest y), the grid's
        resolution, origin and bounds in the map frame, and the rectangles the robot's costmap
        blocks where the map is free (a closed door or an obstacle it saw). {"available":
        false} when the base publishes no map."""
        grid = view.map()
        if grid is None:
            return {"available": False, "detail": "the robot publishes no map (/map)"}
        return floor_view(grid, view.costmap())

    @server.tool(annotations=READ_ONLY)
    async def get_plan() -> dict[str, Any]:
        """The path the base is following now (its global plan, map frame, at most 200
        points), or no points when it is not driving."""
        plan = view.plan()
        since = navigator.drive_started_at()
        pose = navigator.pose()
        if plan is None or since is None or plan.received_at < since or not plan.points:
            return {"frame": pose["frame"], "points": [], "destination": pose["destination"]}
        return {
            "frame": plan.frame,
            "points": plan_points(plan),
            "destination": pose["destination"],
        }

    add_task_tools(server, navigator, "navigation", "the robot halts where it is")
    return server
