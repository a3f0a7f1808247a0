"""/api/map/* — the robot's map for the UI, from navigation's MCP tools: the named places
(with the names people use), the live pose, the floor plan of the robot's own map (``/map``
and its costmap, as small PNG masks) and the plan it is following (``/plan``). The same routes
show a real robot's Nav2 map and plan: navigation reads the standard topics."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter
from fastapi.responses import JSONResponse

from robot_language.places import Place
from robot_voice_chat.api.deps import ContainerDep
from robot_voice_chat.api.tool_json import ToolUnavailableError, call_json

router = APIRouter(prefix="/api/map", tags=["map"])


def place_label(location: dict[str, Any]) -> str:
    """How a person names the place ("Alice's desk", "Kitchen"), never its map id: the head
    of its description when that names it, as the robot says it, capitalised."""
    place = Place(
        str(location.get("name", "")),
        tuple(str(a) for a in location.get("aliases") or ()),
        str(location.get("description", "")),
    )
    spoken = place.spoken()
    spoken = spoken[4:] if spoken.startswith("the ") else spoken
    return spoken[:1].upper() + spoken[1:]


async def _tool(container: ContainerDep, tool: str) -> dict[str, Any] | JSONResponse:
    try:
        return await call_json(
            container.adapters.tools, tool, {}, container.config.ui.tool_timeout_s
        )
    except ToolUnavailableError as exc:
        return exc.response()


@router.get("/locations", operation_id="map_locations", response_model=None)
async def locations(container: ContainerDep) -> dict[str, Any] | JSONResponse:
    answer = await _tool(container, "navigation.list_locations")
    if isinstance(answer, dict):
        for location in answer.get("locations") or []:
            if isinstance(location, dict):
                location["label"] = place_label(location)
    return answer


@router.get("/pose", operation_id="map_pose", response_model=None)
async def pose(container: ContainerDep) -> dict[str, Any] | JSONResponse:
    return await _tool(container, "navigation.get_pose")


@router.get("/floor", operation_id="map_floor", response_model=None)
async def floor(container: ContainerDep) -> dict[str, Any] | JSONResponse:
    """The robot's map: walls and unknown as PNG masks, bounds, blocked rectangles."""
    return await _tool(container, "navigation.get_map")


@router.get("/plan", operation_id="map_plan", response_model=None)
async def plan(container: ContainerDep) -> dict[str, Any] | JSONResponse:
    """The path the robot follows now (no points while it stands)."""
    return await _tool(container, "navigation.get_plan")
