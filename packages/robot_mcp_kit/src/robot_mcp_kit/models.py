"""The Async Task Contract (spec 002 §1, ARCHITECTURE §4.3): the JSON the servers exchange
with the brain about long-running tasks."""

from __future__ import annotations

import time
import uuid
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

SCHEMA_VERSION: int = 1
"""Version of the TaskEvent shape this library writes (and the highest it understands)."""

EventType = Literal["progress", "trigger_fired", "task_done", "task_failed", "watch_event"]
TaskState = Literal["running", "succeeded", "failed", "cancelled"]

EVENT_TYPES: tuple[EventType, ...] = (
    "progress",
    "trigger_fired",
    "task_done",
    "task_failed",
    "watch_event",
)
TERMINAL_EVENT_TYPES: frozenset[EventType] = frozenset({"task_done", "task_failed"})
TASK_STATES: tuple[TaskState, ...] = ("running", "succeeded", "failed", "cancelled")
TERMINAL_STATES: frozenset[TaskState] = frozenset({"succeeded", "failed", "cancelled"})


def new_event_id() -> str:
    return uuid.uuid4().hex


class TaskFailure(BaseModel):
    """Why a task failed: the payload of a ``task_failed`` event."""

    error_code: str = Field(min_length=1)
    message: str
    recoverable: bool = False
    suggestions: list[str] = Field(default_factory=list)


class TaskEvent(BaseModel):
    """One pushed event about one task. ``event_id`` is the dedupe key; ``seq`` orders the
    events of a task (it increases per task, gaps are possible)."""

    model_config = ConfigDict(frozen=True)

    schema_version: int = SCHEMA_VERSION
    event_id: str = Field(default_factory=new_event_id, min_length=1)
    task_id: str = Field(min_length=1)
    server: str = Field(min_length=1)
    tool: str
    type: EventType
    seq: int = Field(ge=0)
    ts: float = Field(default_factory=time.time, description="unix seconds")
    payload: dict[str, Any] = Field(default_factory=dict)

    @model_validator(mode="after")
    def _failed_payload_is_a_task_failure(self) -> TaskEvent:
        if self.type == "task_failed":
            TaskFailure.model_validate(self.payload)
        return self

    @property
    def terminal(self) -> bool:
        return self.type in TERMINAL_EVENT_TYPES

    def failure(self) -> TaskFailure | None:
        """The TaskFailure of a ``task_failed`` event, else None."""
        if self.type != "task_failed":
            return None
        return TaskFailure.model_validate(self.payload)


class TaskInfo(BaseModel):
    """What an async tool returns at once, and what get_task/list_tasks report."""

    model_config = ConfigDict(extra="allow")

    task_id: str = Field(min_length=1)
    state: TaskState = "running"
    est_duration_s: float | None = None
    server: str | None = None
    tool: str | None = None

    def to_json(self) -> str:
        """The JSON an async MCP tool returns (extra fields included)."""
        return self.model_dump_json()
