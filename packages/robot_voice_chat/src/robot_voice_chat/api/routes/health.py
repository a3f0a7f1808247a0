"""Liveness and readiness."""

from __future__ import annotations

from collections.abc import Mapping, Set
from typing import Any

from fastapi import APIRouter

from robot_voice_chat.api.deps import ContainerDep
from robot_voice_chat.api.routes.safety import safety_view

router = APIRouter(prefix="/api", tags=["health"])


@router.get("/livez", operation_id="livez")
async def livez() -> dict[str, str]:
    return {"status": "ok"}


def servers_ready(states: Mapping[str, str], optional: Set[str]) -> bool:
    """Every server that is not optional is connected."""
    return all(state == "connected" for name, state in states.items() if name not in optional)


@router.get("/readyz", operation_id="readyz")
async def readyz(container: ContainerDep) -> dict[str, Any]:
    states = container.adapters.tools.server_states()
    planner = container.adapters.planner
    # a planner chain running on its fallback (the cloud planner failed) is degraded
    planner_degraded = bool(getattr(planner, "degraded", False))
    camera = container.adapters.camera
    # the camera / vision node counts: a mission that looks needs it (issue 23 item 5)
    vision = await camera.health() if camera is not None else None
    optional = {s.name for s in container.config.tools.servers if s.optional}
    ready = (
        servers_ready(states, optional)
        and not planner_degraded
        and (vision is None or vision.state == "ok")
    )
    return {
        "status": "ready" if ready else "degraded",
        "data": {
            "mcp_servers": states,
            "missions_enabled": container.executor.enabled,
            "llm": container.adapters.llm.name,
            "planner": planner.name if planner else None,
            # what reads the operator's words (the status bar shows it)
            "planner_understanding": planner.understanding_label if planner else None,
            "llm_understanding": container.adapters.llm.understanding_label,
            "planner_state": None if planner is None else "degraded" if planner_degraded else "ok",
            "deployment": container.config.deployment,
            "vision": None if vision is None else {"state": vision.state, "detail": vision.detail},
            # these servers' events are refused (401) until they get a secret
            "servers_without_event_secret": container.config.tools.servers_without_event_secret(),
            # HTTP servers the brain has no credential for: they answer 401 (issue 27)
            "servers_without_credential": container.config.tools.servers_without_credential(),
            "safety": safety_view(container).model_dump(),
            "policy": container.policy_summary(),
            # the lease on every motion server (issue 27): fresh, unreachable, unsupported
            "supervision": container.supervisor.summary() if container.supervisor else None,
        },
    }
