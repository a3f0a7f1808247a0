"""One correlation id per mission across processes (deploy/RUNBOOK.md: follow one mission).

The brain puts the mission id into each MCP ``tools/call`` request's ``_meta`` under
:data:`MISSION_META_KEY`. :class:`MissionCorrelation` (a server middleware installed by
``serve_mcp``) binds it as the ``mission_id`` log field for the whole call — and for the tasks
the call starts, which inherit the context — so ``journalctl | grep <mission id>`` shows a
mission's path through every capability server. Events those tasks post carry it too
(``payload["mission_id"]``, set by ``EventPoster.emit``), so the signed event that reaches the
brain names its mission.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from contextvars import ContextVar
from typing import Any, cast

import structlog
from mcp.server.context import CallNext, HandlerResult, ServerRequestContext
from mcp.server.mcpserver import MCPServer
from mcp.types import RequestParamsMeta

MISSION_META_KEY = "robot-stack/mission_id"
_VALID_ID = re.compile(r"^[A-Za-z0-9_.:-]{1,64}$")

logger = structlog.get_logger("robot_mcp_kit.correlation")
_current_mission: ContextVar[str | None] = ContextVar("current_mission", default=None)


def current_mission_id() -> str | None:
    """The mission id of the tool call this code runs for (or a task that call started)."""
    return _current_mission.get()


def mission_meta(mission_id: str | None) -> RequestParamsMeta | None:
    """The request ``_meta`` that carries ``mission_id`` (None when there is no mission)."""
    if not mission_id:
        return None
    meta: dict[str, Any] = {MISSION_META_KEY: mission_id}
    return cast(RequestParamsMeta, meta)


def mission_id_from(meta: Mapping[str, Any] | None) -> str | None:
    """The mission id in a request ``_meta``; None when absent or not a plain short id
    (it ends up in every log line, so nothing else is accepted)."""
    value = (meta or {}).get(MISSION_META_KEY)
    return value if isinstance(value, str) and _VALID_ID.match(value) else None


class MissionCorrelation:
    """Server middleware: a ``tools/call`` with a mission id logs under that id."""

    async def __call__(
        self, ctx: ServerRequestContext[Any, Any], call_next: CallNext
    ) -> HandlerResult:
        mission_id = mission_id_from(ctx.meta) if ctx.method == "tools/call" else None
        if mission_id is None:
            return await call_next(ctx)
        token = _current_mission.set(mission_id)
        try:
            with structlog.contextvars.bound_contextvars(mission_id=mission_id):
                logger.info("mcp_tool_call", tool=(ctx.params or {}).get("name"))
                return await call_next(ctx)
        finally:
            _current_mission.reset(token)


def install_mission_correlation(server: MCPServer) -> MCPServer:
    """Add :class:`MissionCorrelation` to ``server`` (once); returns the server."""
    if not any(isinstance(m, MissionCorrelation) for m in server.middleware):
        server.middleware.append(MissionCorrelation())
    return server
