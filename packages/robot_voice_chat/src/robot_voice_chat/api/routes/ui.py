"""The operator's web app: its built files at ``/`` and what it needs to know at start."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from fastapi import APIRouter, FastAPI, Request
from fastapi.responses import HTMLResponse
from fastapi.staticfiles import StaticFiles

from robot_voice_chat.api.deps import ContainerDep
from robot_voice_chat.settings import PACKAGE_DIR

router = APIRouter(prefix="/api/ui", tags=["ui"])
DEFAULT_STATIC_DIR = PACKAGE_DIR / "static"
NOT_BUILT = """<!doctype html><meta charset="utf-8"><title>UI not built</title>
<p>The operator UI is not built into <code>{dir}</code>. Run <code>make setup</code>
(needs Node 20 and npm), then reload. The REST API under <code>/api</code> works without it.</p>
"""


@router.get("/config", operation_id="ui_config")
async def ui_config(request: Request, container: ContainerDep) -> dict[str, Any]:
    adapters = container.adapters
    auth = any(getattr(route, "path", None) == "/api/auth/me" for route in request.app.routes)
    speech_input = adapters.speech_input.configured
    return {
        "deployment": container.config.deployment,
        "llm": adapters.llm.name,
        "planner": adapters.planner.name if adapters.planner else None,
        "planner_understanding": adapters.planner.understanding_label if adapters.planner else None,
        "llm_understanding": adapters.llm.understanding_label,
        "speech_input": speech_input,
        "speech_input_name": adapters.speech_input.name if speech_input else None,
        "speech_input_reason": None
        if speech_input
        else "No speech input is configured on the robot (speech_input: none).",
        "speech_output_browser": adapters.speech_output.in_browser,
        "camera": adapters.camera is not None,
        "auth": auth,  # operator login present: the UI asks /api/auth/me before it starts
    }


def static_dir(configured: str) -> Path:
    return Path(configured) if configured else DEFAULT_STATIC_DIR


def mount_ui(app: FastAPI, directory: Path) -> None:
    """Serve the build at ``/`` — registered last, so ``/api/*`` routes always win (and
    Socket.IO is answered before FastAPI sees the request)."""
    if (directory / "index.html").is_file():
        app.mount("/", StaticFiles(directory=directory, html=True), name="ui")
        return

    @app.get("/", include_in_schema=False)
    async def not_built() -> HTMLResponse:
        return HTMLResponse(NOT_BUILT.format(dir=directory), status_code=503)
