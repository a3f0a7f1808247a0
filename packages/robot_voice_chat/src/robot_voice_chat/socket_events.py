"""Typed payloads of every Socket.IO event (spec §11.1) — the frontend generates its types here.

Server → client events carry ``EVENT`` (the Socket.IO event name). Client → server events:
``send_message`` (:class:`SendMessage`) and ``stop_pipeline`` (no payload).
"""

from __future__ import annotations

from typing import Any, ClassVar, Literal

from pydantic import BaseModel, Field

StepStatus = Literal["pending", "running", "succeeded", "failed", "skipped"]
MissionState = Literal[
    "planning", "running", "paused", "awaiting_approval", "succeeded", "failed", "cancelled"
]
MissionEventKind = Literal["tool_call", "task_event", "reaction", "say", "user_turn"]


class SocketEvent(BaseModel):
    EVENT: ClassVar[str]


class StepView(BaseModel):
    id: str
    title: str
    tool: str | None = None
    status: StepStatus = "pending"
    detail: str = ""
    task_id: str | None = None


class MissionStarted(SocketEvent):
    EVENT: ClassVar[str] = "mission_started"
    mission_id: str
    instruction: str
    teaching: bool = False
    started_at: float | None = None  # epoch seconds (the UI's elapsed-time clock)


class MissionPlan(SocketEvent):
    """Full snapshot — emitted on set_plan/update_plan and on every step change."""

    EVENT: ClassVar[str] = "mission_plan"
    mission_id: str
    state: MissionState
    steps: list[StepView] = Field(default_factory=list)
    started_at: float | None = None  # epoch seconds
    ended_at: float | None = None


class MissionEventLine(SocketEvent):
    EVENT: ClassVar[str] = "mission_event"
    mission_id: str
    kind: MissionEventKind
    text: str
    ts: float


class SafetyAlarm(BaseModel):
    """A supervision alarm a motion server reports (issue 35): someone other than the brain
    reached for the robot's controls. ``detail`` is the server's plain-English sentence."""

    server: str
    code: str  # FOREIGN_HOLDER, LOCK_TOPIC_SHARED, POSE_TOPIC_SHARED, MAP_TOPIC_SHARED, ...
    detail: str = ""
    at: float = 0.0  # epoch seconds the server raised it


class SafetyState(SocketEvent):
    """The latched software stop (``GET /api/safety`` returns the same fields) and the
    supervision alarms the motion servers report now."""

    EVENT: ClassVar[str] = "safety_state"
    latched: bool
    since: float | None = None  # epoch seconds
    by: str | None = None
    reason: str | None = None
    alarms: list[SafetyAlarm] = Field(default_factory=list)


class ApprovalRequested(SocketEvent):
    """A ``confirm`` tool call waits for an operator's Approve / Deny (issue 21)."""

    EVENT: ClassVar[str] = "approval_requested"
    approval_id: str
    mission_id: str | None = None
    step_id: str | None = None
    tool: str
    arguments: dict[str, Any] = Field(default_factory=dict)
    reason: str
    expires_at: float  # epoch seconds; no answer by then = denied


class ApprovalResolved(SocketEvent):
    EVENT: ClassVar[str] = "approval_resolved"
    approval_id: str
    decision: Literal["approve", "deny"]
    operator: str | None = None  # None: nobody answered (timeout) or the stop denied it
    reason: str = ""


class MissionFinished(SocketEvent):
    EVENT: ClassVar[str] = "mission_finished"
    mission_id: str
    outcome: MissionState
    summary: str
    # planner totals: input/output/cache tokens and cost_usd (null when no price is known)
    usage: dict[str, float | None] | None = None


class TeachingState(SocketEvent):
    EVENT: ClassVar[str] = "teaching_state"
    armed: bool


class TeachingSaved(SocketEvent):
    EVENT: ClassVar[str] = "teaching_saved"
    process_id: str


class TeachingFailed(SocketEvent):
    EVENT: ClassVar[str] = "teaching_failed"
    reason: str


class ChatDelta(SocketEvent):
    """A streamed piece of the fast-path reply."""

    EVENT: ClassVar[str] = "chat_delta"
    turn_id: str
    text: str


class ChatMessage(SocketEvent):
    """A complete conversation line (user echo, assistant reply, mission ack)."""

    EVENT: ClassVar[str] = "chat_message"
    turn_id: str
    role: Literal["user", "assistant"]
    text: str


class ChatError(SocketEvent):
    EVENT: ClassVar[str] = "chat_error"
    turn_id: str
    message: str


class Speak(SocketEvent):
    """One sentence for the browser's TTS queue."""

    EVENT: ClassVar[str] = "speak"
    utterance_id: str
    text: str


class SpeechInterrupted(SocketEvent):
    """Drop every queued ``speak`` sentence and stop talking now."""

    EVENT: ClassVar[str] = "speech_interrupted"


class SendMessage(BaseModel):
    """Client → server ``send_message`` payload."""

    text: str = Field(min_length=1, max_length=4000)


SERVER_EVENTS: tuple[type[SocketEvent], ...] = (
    MissionStarted,
    MissionPlan,
    MissionEventLine,
    MissionFinished,
    SafetyState,
    ApprovalRequested,
    ApprovalResolved,
    TeachingState,
    TeachingSaved,
    TeachingFailed,
    ChatDelta,
    ChatMessage,
    ChatError,
    Speak,
    SpeechInterrupted,
)


def json_schemas() -> dict[str, Any]:
    """Event name → JSON schema (input for the frontend's type generator)."""
    schemas = {cls.EVENT: cls.model_json_schema() for cls in SERVER_EVENTS}
    schemas["send_message"] = SendMessage.model_json_schema()
    return schemas
