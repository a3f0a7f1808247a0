"""/api/agent/approvals — pending approvals, and the operator's Approve / Deny of one."""

from __future__ import annotations

from typing import Any, Literal

from fastapi import APIRouter, HTTPException
from pydantic import BaseModel, Field

from robot_voice_chat.api.deps import ContainerDep
from robot_voice_chat.control.approvals import ApprovalBroker, ApprovalRefusedError
from robot_voice_chat.control.latch import acting

router = APIRouter(prefix="/api/agent/approvals", tags=["approvals"])


class ApprovalDecision(BaseModel):
    decision: Literal["approve", "deny"]
    reason: str = Field("", max_length=200)


def broker(container: Any) -> ApprovalBroker:
    approvals: ApprovalBroker | None = container.executor.approvals
    if approvals is None:
        raise HTTPException(404, "approvals are not configured")
    return approvals


@router.get("", operation_id="list_approvals")
async def list_approvals(container: ContainerDep) -> list[dict[str, Any]]:
    """Pending approvals (the UI's cards after a reload)."""
    return [p.event().model_dump(mode="json") for p in broker(container).pending()]


@router.post("/{approval_id}", operation_id="decide_approval")
async def decide(
    approval_id: str, body: ApprovalDecision, container: ContainerDep
) -> dict[str, Any]:
    operator = acting()
    try:
        request = broker(container).resolve(approval_id, body.decision, operator, body.reason)
    except ApprovalRefusedError as exc:
        raise HTTPException(exc.status, str(exc)) from exc
    return {
        "approval_id": request.approval_id,
        "decision": body.decision,
        "operator": operator,
        "tool": request.tool,
    }
