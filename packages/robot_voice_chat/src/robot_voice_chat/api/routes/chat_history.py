"""GET /api/chat/history — the last conversation lines, so a reload shows them again."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter, Query

from robot_voice_chat.api.deps import ContainerDep

router = APIRouter(prefix="/api/chat", tags=["chat"])


@router.get("/history", operation_id="chat_history")
async def chat_history(
    container: ContainerDep, limit: int = Query(50, ge=1, le=500)
) -> dict[str, Any]:
    return {"lines": container.history.lines(limit)}
