"""/api/map/* — the navigation map and the robot's live pose (navigation's MCP tools)."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter
from fastapi.responses import JSONResponse

from robot_voice_chat.api.deps import ContainerDep
from robot_voice_chat.api.tool_json import ToolUnavailableError, call_json

router = APIRouter(prefix="/api/map", tags=["map"])


@router.get("/locations", operation_id="map_locations", response_model=None)
async def locations(container: ContainerDep) -> dict[str, Any] | JSONResponse:
    try:
        return await call_json(
            container.adapters.tools,
            "navigation.list_locations",
            {},
            container.config.ui.tool_timeout_s,
        )
    except ToolUnavailableError as exc:
        return exc.response()


@router.get("/pose", operation_id="map_pose", response_model=None)
async def pose(container: ContainerDep) -> dict[str, Any] | JSONResponse:
    try:
        return await call_json(
            container.adapters.tools, "navigation.get_pose", {}, container.config.ui.tool_timeout_s
        )
    except ToolUnavailableError as exc:
        return exc.response()
