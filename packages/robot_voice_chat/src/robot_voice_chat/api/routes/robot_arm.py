"""/api/robot/held — what the robot's gripper holds, as the arm's server reports it (the
manipulation server's read-only ``get_held``); a 503 JSON when the robot has no arm connected."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter
from fastapi.responses import JSONResponse

from robot_voice_chat.api.deps import ContainerDep
from robot_voice_chat.api.tool_json import ToolUnavailableError, call_json

router = APIRouter(prefix="/api/robot", tags=["robot"])


@router.get("/held", operation_id="robot_held", response_model=None)
async def held(container: ContainerDep) -> dict[str, Any] | JSONResponse:
    try:
        return await call_json(
            container.adapters.tools,
            "manipulation.get_held",
            {},
            container.config.ui.tool_timeout_s,
        )
    except ToolUnavailableError as exc:
        return exc.response()
