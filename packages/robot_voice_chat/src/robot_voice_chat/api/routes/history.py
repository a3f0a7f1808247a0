"""/api/history — what the robot saw recently, from the episodic memory server, for the UI's
History panel: sightings newest first with their time, place and the robot's pose then.

Errors are JSON ``{"error", "detail"}``: a ``since``/``limit`` the panel cannot use → 422;
episodic not configured or not connected → 503; an episodic tool error → 502 with its message.
"""

from __future__ import annotations

import asyncio
import json
import time
from typing import Any

import structlog
from fastapi import APIRouter
from fastapi.responses import JSONResponse

from robot_voice_chat.api.deps import ContainerDep
from robot_voice_chat.api.episodic_history import (
    DEFAULT_SINCE,
    LAST_SEEN_N,
    SERVER,
    HistoryError,
    check_limit,
    check_since,
    labels_of,
    not_connected,
    sighting_rows,
    tool_failure,
)
from robot_voice_chat.api.tool_json import BACKGROUND_READ
from robot_voice_chat.control.context import dispatching
from robot_voice_chat.services.tools.base import ToolBackend

logger = structlog.get_logger(__name__)
router = APIRouter(prefix="/api", tags=["history"])


@router.get("/history", operation_id="history_sightings", response_model=None)
async def history(
    container: ContainerDep, since: str = DEFAULT_SINCE, limit: int = 50
) -> dict[str, Any] | JSONResponse:
    started = time.monotonic()
    tools = container.adapters.tools
    timeout_s = container.config.ui.tool_timeout_s
    try:
        start = check_since(since, time.time())
        check_limit(limit)
        happened = await _call(
            tools,
            "what_happened",
            {"start": start, "end": "now", "kinds": ["sightings"], "max_items": limit},
            timeout_s,
        )
        details = await asyncio.gather(
            *(_details(tools, label, timeout_s) for label in labels_of(happened))
        )
    except HistoryError as exc:
        logger.info("history_refused", status=exc.status, error=exc.error, detail=exc.detail)
        return JSONResponse(exc.body(), status_code=exc.status)
    rows = sighting_rows(happened, list(details))
    logger.info(
        "history_read",
        rows=len(rows),
        labels=len(details),
        duration_ms=round((time.monotonic() - started) * 1000, 1),
    )
    return {
        "since": (happened.get("start") or {}).get("time"),
        "now": (happened.get("end") or {}).get("time"),
        "count": len(rows),
        "truncated": bool(happened.get("truncated")),
        "sightings": rows,
    }


async def _details(tools: ToolBackend, label: str, timeout_s: float) -> dict[str, Any]:
    """``last_seen`` for one label; a label the server cannot search for (no content words)
    simply keeps its row without a pose."""
    try:
        return await _call(tools, "last_seen", {"query": label, "n": LAST_SEEN_N}, timeout_s)
    except HistoryError as exc:
        if exc.tool_code == "invalid_argument":
            return {}
        raise


async def _call(
    tools: ToolBackend, tool: str, arguments: dict[str, object], timeout_s: float
) -> dict[str, Any]:
    if tools.server_states().get(SERVER) != "connected":
        raise not_connected()
    with dispatching(BACKGROUND_READ):
        outcome = await tools.call_tool(f"{SERVER}.{tool}", arguments, timeout_s=timeout_s)
    if outcome.is_error:
        if tools.server_states().get(SERVER) != "connected":
            raise not_connected()
        raise tool_failure(tool, outcome.text)
    try:
        data = json.loads(outcome.text)
    except ValueError:
        raise HistoryError(502, "episodic_error", f"{tool} answered no JSON") from None
    if not isinstance(data, dict):
        raise HistoryError(502, "episodic_error", f"{tool} answered {type(data).__name__}")
    return data
