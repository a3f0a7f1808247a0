"""GET /api/chat/history — the last conversation lines, so a reload shows them again.

A ``mission_finished`` line is served with its mission's human title (``instruction``), read
from the mission itself (this process life's store, else the archive): a reloaded page shows
the card as "go to the kitchen", never as "Mission m-…" (issue 39)."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter, Query

from robot_voice_chat.api.deps import ContainerDep
from robot_voice_chat.robot_words import plain_instruction

router = APIRouter(prefix="/api/chat", tags=["chat"])


@router.get("/history", operation_id="chat_history")
async def chat_history(
    container: ContainerDep, limit: int = Query(50, ge=1, le=500)
) -> dict[str, Any]:
    lines = container.history.lines(limit)
    titled = []
    for line in lines:
        if line.get("event") == "mission_finished" and "instruction" not in line:
            mission = await container.executor.find_mission(str(line.get("mission_id", "")))
            title = plain_instruction(mission.instruction) if mission is not None else ""
            line = {**line, "instruction": title}
        titled.append(line)
    return {"lines": titled}
