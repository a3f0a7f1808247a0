"""/api/safety — the latched software stop: read it, set it, clear it (operator, with why).

Every answer carries the latch (``latched``, ``since``, ``by``, ``reason``: plain words, e.g.
"another program is publishing on the motion lock of my navigation") and ``alarms``: the
supervision alarms the motion servers report now (``server``, ``code``, ``detail``, ``at``).

A software stop request, not an emergency-stop device: the hardware emergency stop remains
required. Clearing resumes nothing; a paused mission stays paused until someone answers it.
"""

from __future__ import annotations

from fastapi import APIRouter, HTTPException
from pydantic import BaseModel, Field

from robot_voice_chat.api.container import Container
from robot_voice_chat.api.deps import ContainerDep
from robot_voice_chat.control.latch import NotLatchedError, acting
from robot_voice_chat.control.latch_store import LatchState
from robot_voice_chat.socket_events import SafetyState

router = APIRouter(prefix="/api/safety", tags=["safety"])


class StopRequest(BaseModel):
    reason: str = Field("stop requested over the API", min_length=1, max_length=200)


class ClearRequest(BaseModel):
    reason: str = Field(min_length=3, max_length=200, description="why it is safe to move again")


def safety_view(container: Container, state: LatchState | None = None) -> SafetyState:
    """The latch and the alarms the motion servers report now."""
    state = state if state is not None else container.executor.latch.state
    supervisor = container.supervisor
    alarms = supervisor.alarms() if supervisor is not None else []
    return SafetyState(**state.model_dump(), alarms=alarms)


@router.get("", operation_id="get_safety")
async def get_safety(container: ContainerDep) -> SafetyState:
    return safety_view(container)


@router.post("/stop", operation_id="safety_stop")
async def stop(container: ContainerDep, body: StopRequest | None = None) -> SafetyState:
    reason = body.reason if body is not None else StopRequest().reason
    await container.pipeline.stop(reason)
    return safety_view(container)


@router.post("/clear", operation_id="safety_clear")
async def clear(body: ClearRequest, container: ContainerDep) -> SafetyState:
    try:
        return safety_view(container, await container.executor.latch.clear(acting(), body.reason))
    except NotLatchedError as exc:
        raise HTTPException(409, str(exc)) from exc
    except OSError as exc:  # the clear could not be recorded: the stop stays latched
        raise HTTPException(503, f"the clear could not be recorded ({exc}); still latched") from exc
