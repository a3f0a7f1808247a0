"""Approvals: a ``confirm`` tool call waits for an operator's yes, bound to that exact call.

One approval per call: single-use, bound to the tool + its canonical arguments + the mission.
Approve / Deny from the UI card, ``POST /api/agent/approvals/{id}``, or a typed/spoken answer
(only an explicit yes approves). No answer within the timeout denies; a safety stop denies all.
Every decision goes to the mission trace and to an append-only audit log with the operator.
"""

from __future__ import annotations

import asyncio
import hashlib
import json
import time
import uuid
from collections.abc import Awaitable, Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal, Protocol

import structlog

from robot_voice_chat.control.context import DispatchContext
from robot_voice_chat.control.guard import ApprovalAnswer
from robot_voice_chat.control.latch_store import append_record
from robot_voice_chat.robot_words import service_name
from robot_voice_chat.services.emitter.base import EventEmitter
from robot_voice_chat.socket_events import ApprovalRequested, ApprovalResolved

logger = structlog.get_logger(__name__)
Verdict = Literal["approve", "deny"]
StateHook = Callable[["PendingApproval", bool], Awaitable[None]]


class MissionTrace(Protocol):
    """Where each decision is written beside the mission's own lines (the agent's
    ``TraceRecorder``); control sits below the agent and names only what it calls."""

    def record(self, mission_id: str, kind: str, **data: Any) -> None: ...


class ApprovalRefusedError(RuntimeError):
    """An answer that cannot count: unknown, already used (replay), expired, or another call."""

    def __init__(self, status: int, message: str) -> None:
        super().__init__(message)
        self.status = status  # 404 unknown, 409 replay / mismatch, 410 expired


YES = frozenset(
    {
        "yes",
        "yes please",
        "yes do it",
        "yes go ahead",
        "go ahead",
        "approve",
        "approved",
        "i approve",
        "confirm",
        "confirmed",
    }
)
NO = frozenset(
    {
        "no",
        "no thanks",
        "no thank you",
        "nope",
        "deny",
        "denied",
        "i deny",
        "don't",
        "do not",
        "dont",
        "no don't",
        "cancel",
    }
)


def parse_answer(text: str) -> Verdict | None:
    """Only these explicit words count; "yes but not there", "sure?", "maybe" do not."""
    words = " ".join("".join(c if c.isalnum() or c == "'" else " " for c in text.lower()).split())
    if words in YES:
        return "approve"
    if words in NO:
        return "deny"
    return None


def canonical(arguments: dict[str, Any]) -> str:
    return json.dumps(arguments, sort_keys=True, separators=(",", ":"), default=str)


def binding(tool: str, arguments: dict[str, Any], mission_id: str | None) -> str:
    text = f"{mission_id or '-'}\n{tool}\n{canonical(arguments)}"
    return hashlib.sha256(text.encode()).hexdigest()


@dataclass
class PendingApproval:
    approval_id: str
    tool: str
    arguments: dict[str, Any]
    reason: str
    context: DispatchContext
    expires_at: float  # epoch seconds
    deadline: float  # monotonic
    digest: str
    answer: asyncio.Future[tuple[Verdict, str | None, str]] = field(
        default_factory=lambda: asyncio.get_running_loop().create_future()
    )

    def event(self) -> ApprovalRequested:
        return ApprovalRequested(
            approval_id=self.approval_id,
            mission_id=self.context.mission_id,
            step_id=self.context.step_id,
            tool=self.tool,
            arguments=json.loads(canonical(self.arguments)),
            reason=self.reason,
            expires_at=self.expires_at,
        )


# what an approval asks for, as a person hears it (the card shows the exact call)
_ASKED = {
    "navigate_to": "driving to {place}",
    "save_process": "storing a process I was taught",
    "forget": "deleting recordings from my memory",
    "instantiate_raw_skill": "starting a custom camera skill",
}


def asked_for(tool: str, arguments: dict[str, Any]) -> str:
    """``navigation.navigate_to {location: desk_alice}`` → "driving to the desk alice"."""
    server, _, name = tool.partition(".")
    template = _ASKED.get(name)
    if template is None:
        return f"an action of my {service_name(server)}"
    place = str(arguments.get("location") or "").replace("_", " ")
    return template.format(place=f"the {place}" if place else "a place")


class ApprovalBroker:
    """The :class:`ApprovalGate` of the guard; the UI, REST and chat answer through it."""

    def __init__(
        self,
        *,
        emitter: EventEmitter,
        trace: MissionTrace,
        audit_path: Path,
        timeout_s: float = 60.0,
    ) -> None:
        self.emitter = emitter
        self.trace = trace
        self.audit_path = audit_path
        self.timeout_s = timeout_s
        self._pending: dict[str, PendingApproval] = {}
        self._resolved: dict[str, str] = {}  # approval_id → how it ended (replays refused)
        self._hooks: list[StateHook] = []

    def add_state_hook(self, hook: StateHook) -> None:
        """``hook(approval, waiting)``: the executor moves its mission in/out of
        ``awaiting_approval``."""
        self._hooks.append(hook)

    def pending(self, mission_id: str | None = None) -> list[PendingApproval]:
        return [
            p
            for p in self._pending.values()
            if mission_id is None or p.context.mission_id == mission_id
        ]

    async def ask(
        self,
        tool: str,
        arguments: dict[str, Any],
        reason: str,
        context: DispatchContext,
        timeout_s: float | None = None,
    ) -> ApprovalAnswer:
        """``timeout_s`` (default: the configured one) — shorter when the asker cannot wait
        as long (an MCP server's question inside a tool call with its own deadline)."""
        timeout = min(self.timeout_s, timeout_s) if timeout_s is not None else self.timeout_s
        frozen = json.loads(canonical(arguments))  # what the operator sees is what is bound
        request = PendingApproval(
            approval_id=f"ap-{uuid.uuid4().hex[:12]}",
            tool=tool,
            arguments=frozen,
            reason=reason,
            context=context,
            expires_at=time.time() + timeout,
            deadline=time.monotonic() + timeout,
            digest=binding(tool, frozen, context.mission_id),
        )
        self._pending[request.approval_id] = request
        self._record(request, "approval_requested", tool=tool, arguments=frozen, reason=reason)
        logger.info("approval_requested", approval_id=request.approval_id, tool=tool)
        verdict: Verdict = "deny"
        operator: str | None = None
        why = "the call was abandoned (mission ended)"
        try:
            for hook in self._hooks:
                await hook(request, True)
            await self.emitter.emit(request.event())
            async with asyncio.timeout(timeout):
                verdict, operator, why = await asyncio.shield(request.answer)
        except TimeoutError:
            if request.answer.done():  # answered in the same instant: the answer counts
                verdict, operator, why = request.answer.result()
            else:
                why = f"no answer within {timeout:g} s"
                self._finish(request, "deny", None, why, "expired")
        finally:
            self._finish(request, "deny", None, why, "denied")  # no-op when already answered
            for hook in self._hooks:
                await hook(request, False)
            await self.emitter.emit(
                ApprovalResolved(
                    approval_id=request.approval_id, decision=verdict, operator=operator, reason=why
                )
            )
        if verdict != "approve":
            return ApprovalAnswer(False, f"denied ({why})")
        # the call is redeemed here, once: its arguments must still be the approved ones
        if binding(tool, arguments, context.mission_id) != request.digest:
            logger.warning("approval_mismatch", approval_id=request.approval_id, tool=tool)
            return ApprovalAnswer(False, "its arguments changed after the approval")
        return ApprovalAnswer(
            True, f"approved by {operator}", approval_id=request.approval_id, operator=operator
        )

    def resolve(
        self,
        approval_id: str,
        verdict: Verdict,
        operator: str,
        reason: str = "",
        *,
        tool: str | None = None,
        arguments: dict[str, Any] | None = None,
        mission_id: str | None = None,
    ) -> PendingApproval:
        """Answer one pending approval. ``tool``/``arguments``/``mission_id``, when given,
        must be exactly the call it was asked for (an answer never carries over)."""
        request = self._pending.get(approval_id)
        if request is None:
            ended = self._resolved.get(approval_id)
            if ended == "expired":
                raise ApprovalRefusedError(410, f"approval {approval_id} expired (denied)")
            if ended is not None:
                raise ApprovalRefusedError(409, f"approval {approval_id} was already {ended}")
            raise ApprovalRefusedError(404, f"no approval {approval_id}")
        if time.monotonic() >= request.deadline:
            raise ApprovalRefusedError(410, f"approval {approval_id} expired (denied)")
        if tool is not None or arguments is not None or mission_id is not None:
            asked = binding(
                tool if tool is not None else request.tool,
                arguments if arguments is not None else request.arguments,
                mission_id if mission_id is not None else request.context.mission_id,
            )
            if asked != request.digest:
                raise ApprovalRefusedError(
                    409, f"approval {approval_id} is for {request.tool} with other arguments"
                )
        ended = "approved" if verdict == "approve" else "denied"
        self._finish(request, verdict, operator, reason or f"{ended} by {operator}", ended)
        return request

    def answer_from_chat(self, text: str, mission_id: str | None, operator: str) -> str | None:
        """A typed/spoken answer to the pending approval(s) of ``mission_id``: only an
        explicit yes approves, an explicit no denies, anything else asks again. None when
        nothing is pending (the text is an ordinary turn)."""
        pending = self.pending(mission_id)
        if not pending:
            return None
        verdict = parse_answer(text)
        if verdict is None:
            asked = " and ".join(asked_for(p.tool, p.arguments) for p in pending)
            return f"I'm waiting for your yes or no to {asked}. Please answer yes or no."
        for request in pending:
            self._finish(request, verdict, operator, f"answered {text!r}", verdict + "d")
        return "Approved." if verdict == "approve" else "Denied: I won't do that."

    def deny_all(self, reason: str, mission_id: str | None = None) -> None:
        """A safety stop (or the mission's end) denies every pending approval."""
        for request in self.pending(mission_id):
            self._finish(request, "deny", None, reason, "denied")

    def _finish(
        self,
        request: PendingApproval,
        verdict: Verdict,
        operator: str | None,
        reason: str,
        ended: str,
    ) -> None:
        if request.approval_id in self._resolved:
            return
        self._resolved[request.approval_id] = ended
        self._pending.pop(request.approval_id, None)
        if not request.answer.done():
            request.answer.set_result((verdict, operator, reason))
        self._record(request, "approval_resolved", decision=verdict, by=operator, reason=reason)
        logger.warning(
            "approval_resolved",
            approval_id=request.approval_id,
            tool=request.tool,
            decision=verdict,
            operator=operator,
            reason=reason,
        )

    def _record(self, request: PendingApproval, kind: str, **data: Any) -> None:
        record = {
            "ts": time.time(),
            "event": kind,
            "approval_id": request.approval_id,
            "mission_id": request.context.mission_id,
            "step_id": request.context.step_id,
            "tool": request.tool,
            "digest": request.digest,
            **data,
        }
        if request.context.mission_id is not None:
            fields = {k: v for k, v in record.items() if k not in ("ts", "mission_id")}
            self.trace.record(request.context.mission_id, kind, **fields)
        try:
            append_record(self.audit_path, record)  # small, fsync'd; the audit must not lag
        except OSError:
            logger.exception("approval_audit_write_failed", approval_id=request.approval_id)
