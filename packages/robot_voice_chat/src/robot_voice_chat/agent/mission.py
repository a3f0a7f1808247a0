"""Mission domain model (spec §4): missions, plan steps, the store and the plan rules."""

from __future__ import annotations

import uuid
from dataclasses import dataclass, field
from datetime import UTC, datetime
from typing import Any, Literal

from robot_voice_chat.services.llm.base import Usage
from robot_voice_chat.socket_events import MissionPlan, StepView

MissionState = Literal[
    "planning", "running", "paused", "awaiting_approval", "succeeded", "failed", "cancelled"
]
StepStatus = Literal["pending", "running", "succeeded", "failed", "skipped"]
ACTIVE_STATES: frozenset[str] = frozenset({"planning", "running", "paused", "awaiting_approval"})
TERMINAL_STEP: frozenset[str] = frozenset({"succeeded", "failed", "skipped"})


def now() -> datetime:
    return datetime.now(UTC)


@dataclass
class PlanStep:
    id: str
    title: str
    tool: str | None = None
    status: StepStatus = "pending"
    detail: str = ""
    task_id: str | None = None
    started_at: datetime | None = None
    ended_at: datetime | None = None

    def set_status(self, status: StepStatus, detail: str | None = None) -> None:
        if status == "running" and self.started_at is None:
            self.started_at = now()
        if status in TERMINAL_STEP:
            self.ended_at = now()
        self.status = status
        if detail is not None:
            self.detail = detail


@dataclass
class Mission:
    id: str
    instruction: str
    state: MissionState
    steps: list[PlanStep]
    created_at: datetime
    summary: str = ""
    teaching: bool = False
    used_process_ids: list[str] = field(default_factory=list)
    ended_at: datetime | None = None
    usage: Usage = field(default_factory=Usage)  # planner token + cost totals

    @classmethod
    def new(cls, instruction: str, teaching: bool = False) -> Mission:
        return cls(
            id="m-" + uuid.uuid4().hex[:6],
            instruction=instruction,
            state="planning",
            steps=[],
            created_at=now(),
            teaching=teaching,
        )

    @property
    def active(self) -> bool:
        return self.state in ACTIVE_STATES

    def step(self, step_id: str | None) -> PlanStep | None:
        return next((s for s in self.steps if s.id == step_id), None)

    def snapshot(self) -> MissionPlan:
        return MissionPlan(
            mission_id=self.id,
            state=self.state,
            steps=[
                StepView(
                    id=s.id,
                    title=s.title,
                    tool=s.tool,
                    status=s.status,
                    detail=s.detail,
                    task_id=s.task_id,
                )
                for s in self.steps
            ],
            started_at=self.created_at.timestamp(),
            ended_at=self.ended_at.timestamp() if self.ended_at else None,
        )

    def summary_row(self) -> dict[str, Any]:
        counts: dict[str, int] = {}
        for s in self.steps:
            counts[s.status] = counts.get(s.status, 0) + 1
        return {
            "id": self.id,
            "instruction": self.instruction,
            "state": self.state,
            "started": self.created_at.isoformat(),
            "ended": self.ended_at.isoformat() if self.ended_at else None,
            "steps": counts,
            "usage": self.usage.model_dump(),
        }


def apply_plan(mission: Mission, new_steps: list[dict[str, Any]], *, replace: bool) -> None:
    """set_plan (``replace``) or update_plan (§5.3): terminal steps keep their status, new ids
    start pending, removed pending steps become skipped."""
    old = {s.id: s for s in mission.steps}
    seen: set[str] = set()
    result: list[PlanStep] = []
    for raw in new_steps:
        step_id, title = str(raw["id"]), str(raw["title"])
        if step_id in seen:
            raise ValueError(f"duplicate step id {step_id!r}")
        seen.add(step_id)
        tool = raw.get("tool")
        kept = None if replace else old.get(step_id)
        if kept is not None:
            kept.title = title
            kept.tool = tool if tool is not None else kept.tool
            result.append(kept)
        else:
            result.append(PlanStep(id=step_id, title=title, tool=tool))
    if not replace:
        for step in mission.steps:
            if step.id in seen:
                continue
            if step.status == "pending":
                step.set_status("skipped", "removed from the plan")
            result.append(step)
    mission.steps = result


class MissionStore:
    """The current mission and recent finished ones (in memory; history also in traces)."""

    def __init__(self, keep: int = 50) -> None:
        self._missions: dict[str, Mission] = {}
        self._keep = keep

    def add(self, mission: Mission) -> None:
        self._missions[mission.id] = mission
        while len(self._missions) > self._keep:
            self._missions.pop(next(iter(self._missions)))

    def get(self, mission_id: str) -> Mission | None:
        return self._missions.get(mission_id)

    def active(self) -> Mission | None:
        return next((m for m in self._missions.values() if m.active), None)

    def recent(self, limit: int = 20) -> list[Mission]:
        return list(reversed(list(self._missions.values())))[:limit]
