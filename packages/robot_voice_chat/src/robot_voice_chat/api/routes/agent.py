"""/api/agent/* — the signed event ingress (§3), missions, teaching."""

from __future__ import annotations

import json
import sqlite3
from typing import Any

import structlog
from fastapi import APIRouter, HTTPException, Request
from fastapi.responses import JSONResponse
from pydantic import BaseModel, ValidationError

from robot_mcp_kit.models import SCHEMA_VERSION, TaskEvent
from robot_mcp_kit.signing import (
    HEADER_SERVER,
    HEADER_SIGNATURE,
    HEADER_TIMESTAMP,
)
from robot_voice_chat.api.deps import ContainerDep
from robot_voice_chat.api.ingress import (
    BodyTooLargeError,
    DedupeLRU,
    RateLimit,
    Unauthorized,
    authenticate,
    json_depth,
    read_limited,
    single_header,
)
from robot_voice_chat.api.seen_events import SeenEvents
from robot_voice_chat.settings import ApiConfig

logger = structlog.get_logger(__name__)
EVENTS_PATH = "/api/agent/events"


class TeachingRequest(BaseModel):
    enabled: bool


def _reject(status: int, reason: str, server: str | None) -> JSONResponse:
    """401s all look alike to the client (no hint which server names exist); the log says why."""
    if status == 401:
        logger.warning("agent_event_rejected", reason=reason, server=server)
        return JSONResponse({"status": "rejected", "reason": "unauthorized"}, status_code=401)
    logger.info("agent_event_invalid", status=status, reason=reason, server=server)
    return JSONResponse({"status": "rejected", "reason": reason}, status_code=status)


def _rate_limited(scope: str, key: str) -> JSONResponse:
    logger.warning("agent_event_rate_limited", scope=scope, key=key)
    return JSONResponse({"status": "rate_limited"}, status_code=429, headers={"Retry-After": "60"})


def build_router(api: ApiConfig, stored: SeenEvents | None = None) -> APIRouter:
    """``stored``: where handled event ids outlive the process (None: this life only)."""
    router = APIRouter(prefix="/api/agent", tags=["agent"])
    seen = DedupeLRU(api.dedupe_size)
    loaded = stored is None

    async def remembered() -> DedupeLRU:
        nonlocal loaded
        if not loaded and stored is not None:
            for event_id in await stored.newest(api.dedupe_size):
                seen.add(event_id)
            loaded = True
        return seen

    per_server = RateLimit(api.event_rate_limit)
    per_client = RateLimit(api.unsigned_rate_limit)

    @router.post("/events", operation_id="post_task_event")
    async def post_event(request: Request, container: ContainerDep) -> JSONResponse:
        server = single_header(request, HEADER_SERVER)
        client = request.client.host if request.client else "?"
        try:
            body = await read_limited(request, api.max_event_body_bytes)
        except BodyTooLargeError:
            return _reject(413, "body_too_large", server)
        try:
            authenticate(
                container.adapters.tools.servers(),
                server,
                single_header(request, HEADER_TIMESTAMP),
                single_header(request, HEADER_SIGNATURE),
                body,
                api.signature_tolerance_s,
            )
        except Unauthorized as exc:
            if not per_client.hit(client):  # floods of unsigned requests, per address
                return _rate_limited("client", client)
            return _reject(401, exc.reason, server)
        assert server is not None
        if not per_server.hit(server):  # keyed by the verified server only
            return _rate_limited("server", server)
        try:
            data = json.loads(body)
        except (ValueError, UnicodeDecodeError):
            return _reject(400, "malformed_json", server)
        except RecursionError:  # nesting deeper than the parser's stack
            return _reject(400, "json_too_deep", server)
        if json_depth(data) > api.max_event_json_depth:
            return _reject(400, "json_too_deep", server)
        if not isinstance(data, dict):
            return _reject(400, "body_must_be_an_object", server)
        version = data.get("schema_version")
        if isinstance(version, int) and not isinstance(version, bool) and version > SCHEMA_VERSION:
            return _reject(400, f"unsupported_schema_version:{version}", server)
        try:
            event = TaskEvent.model_validate(data)
        except ValidationError as exc:
            fields = ",".join(".".join(map(str, e["loc"])) for e in exc.errors())
            return _reject(400, f"invalid_event:{fields}"[:200], server)
        if event.server != server:
            return _reject(400, "server_mismatch", server)
        owner = container.executor.task_server(event.task_id)
        if owner is not None and owner != server:
            return _reject(400, "task_of_another_server", server)
        if not (await remembered()).reserve(event.event_id):
            return JSONResponse({"status": "duplicate"})
        try:
            handled = await container.executor.on_task_event(event)
        except Exception:  # boundary: never 500; the poster retries (reservation released)
            seen.release(event.event_id)
            logger.exception("agent_event_handling_failed", event_id=event.event_id)
            return JSONResponse({"status": "retry"}, status_code=503)
        if stored is not None:
            try:
                await stored.add(event.event_id)
            except sqlite3.Error:  # handled already: a restart may take a replay as new
                logger.exception("agent_event_id_not_stored", event_id=event.event_id)
        logger.info("agent_event_accepted", server=server, type=event.type, task_id=event.task_id)
        return JSONResponse({"status": "accepted" if handled else "orphan"})

    @router.get("/missions", operation_id="list_missions")
    async def list_missions(container: ContainerDep, limit: int = 20) -> dict[str, Any]:
        live = [m.summary_row() for m in await container.executor.recent_missions(limit)]
        ids = {row["id"] for row in live}
        history = [r for r in await container.trace.history(limit) if r["id"] not in ids]
        active = container.executor.active
        return {
            "active": active.id if active else None,
            "missions": (live + history)[:limit],
        }

    @router.get("/missions/{mission_id}", operation_id="get_mission")
    async def get_mission(mission_id: str, container: ContainerDep) -> dict[str, Any]:
        """The snapshot (as ``mission_plan``), the log (``mission_event`` lines) and the trace
        records of its tool results and events; earlier process lives come from the archive."""
        executor = container.executor
        mission = await executor.find_mission(mission_id)
        if mission is None:
            raise HTTPException(404, f"no mission {mission_id}")
        log = await executor.archive.events(mission_id) if executor.archive else []
        events = await container.trace.read(mission_id)
        return {
            **mission.snapshot().model_dump(mode="json"),
            "instruction": mission.instruction,
            "summary": mission.summary,
            "teaching": mission.teaching,
            "log": [line.model_dump(mode="json") for line in log],
            "usage": mission.usage.model_dump(),
            "events": [
                e
                for e in events
                if e.get("kind") in ("task_event", "tool_result", "user_turn", "reaction")
            ],
        }

    @router.get("/teaching", operation_id="get_teaching")
    async def get_teaching(container: ContainerDep) -> dict[str, bool]:
        return {"enabled": container.teaching.armed}

    @router.post("/teaching", operation_id="set_teaching")
    async def set_teaching(body: TeachingRequest, container: ContainerDep) -> dict[str, bool]:
        await container.teaching.arm(body.enabled)
        return {"enabled": container.teaching.armed}

    return router
