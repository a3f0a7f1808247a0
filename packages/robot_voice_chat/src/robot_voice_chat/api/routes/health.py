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
    planner = container.adapters.planner
    # a planner chain running on its fallback (the cloud planner failed) is degraded
    planner_degraded = bool(getattr(planner, "degraded", False))
    ready = all(s == "connected" for s in states.values()) and not planner_degraded
    return {
        "status": "ready" if ready else "degraded",
        "data": {
            "mcp_servers": states,
            "missions_enabled": container.executor.enabled,
            "llm": container.adapters.llm.name,
            "planner": planner.name if planner else None,
            "planner_state": None if planner is None else "degraded" if planner_degraded else "ok",
            "deployment": container.config.deployment,
            # these servers' events are refused (401) until they get a secret
            "servers_without_event_secret": container.config.tools.servers_without_event_secret(),
            "safety": container.executor.latch.state.model_dump(),
            "policy": container.policy_summary(),
        },
    }
