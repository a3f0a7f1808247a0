"""Liveness and readiness."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter

from robot_voice_chat.api.deps import ContainerDep

router = APIRouter(prefix="/api", tags=["health"])


@router.get("/livez", operation_id="livez")
async def livez() -> dict[str, str]:
    return {"status": "ok"}


@router.get("/readyz", operation_id="readyz")
async def readyz(container: ContainerDep) -> dict[str, Any]:
    states = container.adapters.tools.server_states()
    return {
        "status": "ready" if all(s == "connected" for s in states.values()) else "degraded",
        "data": {
            "mcp_servers": states,
            "missions_enabled": container.executor.enabled,
            "llm": container.adapters.llm.name,
            "planner": container.adapters.planner.name if container.adapters.planner else None,
            "deployment": container.config.deployment,
            # these servers' events are refused (401) until they get a secret
            "servers_without_event_secret": container.config.tools.servers_without_event_secret(),
        },
    }
