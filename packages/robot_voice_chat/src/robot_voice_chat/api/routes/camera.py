"""/api/camera/* — the vision node's latest frame (one origin for the browser) and the
current detections from the perception buffer. Offline → 503 JSON, never a 500."""

from __future__ import annotations

import time
from typing import Any

from fastapi import APIRouter
from fastapi.responses import JSONResponse, Response

from robot_voice_chat.api.deps import ContainerDep
from robot_voice_chat.api.tool_json import ToolUnavailableError, call_json, unavailable
from robot_voice_chat.services.camera.base import IMAGE_TYPES, CameraOfflineError

router = APIRouter(prefix="/api/camera", tags=["camera"])
NO_STORE = {"Cache-Control": "no-store"}


@router.get("/frame", operation_id="camera_frame", response_model=None)
async def camera_frame(container: ContainerDep) -> Response:
    camera = container.adapters.camera
    if camera is None:
        return unavailable("camera_offline", "no camera is configured")
    try:
        frame = await camera.latest_frame()
    except CameraOfflineError as exc:
        return unavailable("camera_offline", str(exc))
    if frame.media_type not in IMAGE_TYPES:  # whatever the adapter: only images are served
        return unavailable("camera_offline", f"the camera sent {frame.media_type!r}, not an image")
    return Response(frame.data, media_type=frame.media_type, headers=NO_STORE)


def detection_rows(scene: dict[str, Any]) -> list[dict[str, Any]]:
    """Flatten what_do_you_see's per-skill results into (label, score, skill, age_s) rows."""
    rows = []
    for skill in scene.get("skills") or []:
        for det in skill.get("detections") or []:
            rows.append(
                {
                    "label": str(det.get("label", "?")),
                    "score": det.get("score"),
                    "skill": str(skill.get("skill", "?")),
                    "age_s": skill.get("age_s"),
                    "stale": bool(det.get("stale") or skill.get("stale")),
                }
            )
    return rows


@router.get("/detections", operation_id="camera_detections", response_model=None)
async def detections(container: ContainerDep) -> dict[str, Any] | JSONResponse:
    timeout = container.config.ui.tool_timeout_s
    try:
        scene = await call_json(container.adapters.tools, "perception.what_do_you_see", {}, timeout)
    except ToolUnavailableError as exc:
        return exc.response()
    description = scene.get("scene_description") or {}
    described = isinstance(description, dict)
    return {
        "ts": time.time(),
        "mode": scene.get("mode"),
        "scene": description.get("value") if described else None,
        "scene_age_s": description.get("age_s") if described else None,
        "detections": detection_rows(scene),
    }
