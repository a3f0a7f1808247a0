"""/api/safety — the latched software stop: read it, set it, clear it (operator, with why).

A software stop request, not an emergency-stop device: the hardware emergency stop remains
required. Clearing resumes nothing; a paused mission stays paused until someone answers it.
"""

from __future__ import annotations

from fastapi import APIRouter, HTTPException
from pydantic import BaseModel, Field

from robot_voice_chat.api.deps import ContainerDep
from robot_voice_chat.control.latch import NotLatchedError, acting
from robot_voice_chat.control.latch_store import LatchState

router = APIRouter(prefix="/api/safety", tags=["safety"])


class StopRequest(BaseModel):
    reason: str = Field("stop requested over the API", min_length=1, max_length=200)


class ClearRequest(BaseModel):
    reason: str = Field(min_length=3, max_length=200, description="why it is safe to move again")


@router.get("", operation_id="get_safety")
async def get_safety(container: ContainerDep) -> LatchState:
    return container.executor.latch.state


@router.post("/stop", operation_id="safety_stop")
async def stop(container: ContainerDep, body: StopRequest | None = None) -> LatchState:
    reason = body.reason if body is not None else StopRequest().reason
    await container.pipeline.stop(reason)
    return container.executor.latch.state


@router.post("/clear", operation_id="safety_clear")
async def clear(body: ClearRequest, container: ContainerDep) -> LatchState:
    try:
        return await container.executor.latch.clear(acting(), body.reason)
    except NotLatchedError as exc:
        raise HTTPException(409, str(exc)) from exc
    except OSError as exc:  # the clear could not be recorded: the stop stays latched
        raise HTTPException(503, f"the clear could not be recorded ({exc}); still latched") from exc
