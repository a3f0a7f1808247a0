"""The one choke point in front of every MCP dispatch of the brain.

Every caller (the mission dispatcher for any planner, prepared reactions, the fast path, the
memory client, the UI's routes, the stop itself) holds this backend, never the raw one, so a
call that the latch or the policy refuses is never sent. Refusals are tool errors the planner
can read and replan on: ``{"error": CODE, "detail": sentence}``.
"""

from __future__ import annotations

import json
import time
import uuid
from dataclasses import dataclass
from typing import Any, Protocol

import structlog

from robot_mcp_kit.supervision import SUPERVISE_TOOL
from robot_voice_chat.control.context import DispatchContext, current_dispatch
from robot_voice_chat.control.latch import SAFETY_STOP_LATCHED, SafetyLatch, latched_sentence
from robot_voice_chat.control.policy import POLICY_DENIED, Decision, ToolPolicy
from robot_voice_chat.control.supervisor import MotionSupervisor
from robot_voice_chat.services.llm.base import ToolDefinition
from robot_voice_chat.services.tools.base import (
    ApprovedCall,
    ConnectionState,
    ElicitationHandler,
    ServerListener,
    ToolBackend,
    ToolOutcome,
    approved_call,
)
from robot_voice_chat.settings import McpServerConfig

logger = structlog.get_logger(__name__)
# tools of a motion server that stop or observe: never refused by the latch (with the
# server's own ``read_tools`` from the brain's config; never what its annotations claim)
TASK_READ_TOOLS = frozenset({"get_task", "list_tasks"})
STOP_TOOLS = frozenset({"cancel_task"})
MOTION_READY_WAIT_S = 5.0  # a server's post-clear sweep retries an unanswered cancel each 1 s


def refusal(code: str, detail: str, **extra: object) -> ToolOutcome:
    return ToolOutcome(text=json.dumps({"error": code, "detail": detail, **extra}), is_error=True)


@dataclass(frozen=True)
class ApprovalAnswer:
    approved: bool
    detail: str  # "approved by alice", "denied by bob: wrong room", "no answer within 60 s"
    approval_id: str | None = None  # when approved: which approval, and who gave it
    operator: str | None = None


class ApprovalGate(Protocol):
    """Asks an operator about one exact call and waits for the answer (approvals.py)."""

    async def ask(
        self, tool: str, arguments: dict[str, Any], reason: str, context: DispatchContext
    ) -> ApprovalAnswer: ...


class GuardedToolBackend(ToolBackend):
    """``policy=None`` (test harnesses only) allows every tool; the latch always holds."""

    def __init__(
        self,
        inner: ToolBackend,
        latch: SafetyLatch,
        policy: ToolPolicy | None = None,
        approvals: ApprovalGate | None = None,
        supervisor: MotionSupervisor | None = None,
    ) -> None:
        self.inner = inner
        self.latch = latch
        self.policy = policy
        self.approvals = approvals
        self.supervisor = supervisor  # a motion call waits for a fresh lease (issue 27)

    def is_supervision_tool(self, name: str) -> bool:
        """A motion server's lease tool: the brain's supervisor sends it on the raw backend;
        no planner, reaction, fast path or route may (it could lift a server's latch)."""
        server, _, tool = name.partition(".")
        cfg = self.inner.servers().get(server)
        return tool == SUPERVISE_TOOL and cfg is not None and cfg.motion

    def is_stop_tool(self, name: str) -> bool:
        server, _, tool = name.partition(".")
        cfg = self.inner.servers().get(server)
        return tool in STOP_TOOLS or (cfg is not None and tool == cfg.safety_stop_tool)

    def moves(self, name: str) -> bool:
        """A call that can make the robot move: any tool of a motion server except its stop
        tools and the reads on the brain's own list (``read_tools`` + the task reads). A
        motion server's annotations are not trusted here: ``readOnlyHint`` passes nothing."""
        server, _, tool = name.partition(".")
        cfg = self.inner.servers().get(server)
        if cfg is None or not cfg.motion or self.is_stop_tool(name):
            return False
        return tool not in TASK_READ_TOOLS and tool not in cfg.read_tools

    def definition(self, name: str) -> ToolDefinition | None:
        return next((t for t in self.inner.list_tools() if t.name == name), None)

    def decide(self, name: str, arguments: dict[str, Any]) -> Decision:
        """The policy's decision for one call (stop tools are never gated)."""
        if self.policy is None or self.is_stop_tool(name):
            return Decision("allow", source="default")
        server = self.inner.servers().get(name.partition(".")[0])
        definition = self.definition(name)
        return self.policy.decide(
            name,
            arguments,
            definition.annotations if definition is not None else None,
            server is not None and server.motion,
        )

    def vet_reaction(self, name: str, arguments: dict[str, Any]) -> str | None:
        """A prepared reaction may only call what the policy allows without asking: None if
        it may, else the refusal (JSON) to give the planner at registration."""
        decision = self.decide(name, arguments)
        if decision.action == "allow":
            return None
        logger.warning("reaction_refused", tool=name, code=decision.code or POLICY_DENIED)
        if decision.action == "confirm":
            detail = (
                f"a prepared reaction cannot call {name}: the operator's policy wants an "
                "approval for it, and reactions never wait for one. Call it as a step instead."
            )
            return refusal(POLICY_DENIED, detail).text
        extra = {"bound": decision.bound} if decision.bound else {}
        return refusal(decision.code or POLICY_DENIED, decision.detail, **extra).text

    def latched_refusal(self, name: str) -> ToolOutcome | None:
        if not (self.latch.latched and self.moves(name)):
            return None
        logger.warning("tool_refused", tool=name, code=SAFETY_STOP_LATCHED)
        detail = f"{name} was not sent. " + latched_sentence(self.latch.state)
        return refusal(SAFETY_STOP_LATCHED, detail)

    async def call_tool(
        self, name: str, arguments: dict[str, object], timeout_s: float | None = None
    ) -> ToolOutcome:
        if self.is_supervision_tool(name):
            logger.warning("tool_refused", tool=name, code=POLICY_DENIED)
            return refusal(POLICY_DENIED, f"{name} is reserved for the robot's supervisor")
        refused = self.latched_refusal(name)
        if refused is not None:
            return refused
        started = time.perf_counter()
        decision = self.decide(name, arguments)
        check_ms = round((time.perf_counter() - started) * 1000, 3)
        if decision.action == "deny":
            logger.warning(
                "tool_refused",
                tool=name,
                code=decision.code,
                detail=decision.detail,
                duration_ms=check_ms,
            )
            extra = {"bound": decision.bound} if decision.bound else {}
            return refusal(decision.code or POLICY_DENIED, decision.detail, **extra)
        approval: ApprovedCall | None = None
        if decision.action == "confirm" and current_dispatch().approved_by is not None:
            by = (current_dispatch().approved_by or "operator")[:128]  # what an approval holds
            approval = ApprovedCall(name, dict(arguments), f"pre-{uuid.uuid4().hex[:12]}", by)
            logger.info("tool_preapproved", tool=name, by=by, approval_id=approval.approval_id)
        elif decision.action == "confirm":
            answer = await self._ask(name, arguments, decision)
            if not answer.approved:
                logger.warning("tool_refused", tool=name, code=POLICY_DENIED, detail=answer.detail)
                text = f"{name} was not sent: {answer.detail}"
                return refusal(POLICY_DENIED, text, approval="denied")
            refused = self.latched_refusal(name)  # a stop may have come while we asked
            if refused is not None:
                return refused
            if answer.approval_id is not None:  # the server may ask for the proof
                approval = ApprovedCall(
                    name, dict(arguments), answer.approval_id, answer.operator or "operator"
                )
        if self.supervisor is not None and self.moves(name):
            # right after a (re)connect the first lease may still be on its way (the server
            # refuses motion without one: NOT_SUPERVISED), and right after a clear the server
            # sweeps the goals below it before its lock opens: let both land first
            await self.supervisor.ready_for_motion(name.partition(".")[0], MOTION_READY_WAIT_S)
            refused = self.latched_refusal(name)
            if refused is not None:
                return refused
        if approval is None:
            return await self.inner.call_tool(name, arguments, timeout_s)
        token = approved_call.set(approval)
        try:
            return await self.inner.call_tool(name, arguments, timeout_s)
        finally:
            approved_call.reset(token)

    async def _ask(
        self, name: str, arguments: dict[str, Any], decision: Decision
    ) -> ApprovalAnswer:
        context = current_dispatch()
        if self.approvals is None or not context.may_ask:
            who = context.caller or (
                "a prepared reaction" if not context.may_ask else "this caller"
            )
            return ApprovalAnswer(
                False, f"it needs an operator's approval, which {who} cannot ask for"
            )
        reason = decision.detail or "the operator's policy asks for approval"
        return await self.approvals.ask(name, arguments, reason, context)

    # --- the rest of the port, unchanged -------------------------------------------------
    def list_tools(self) -> list[ToolDefinition]:
        return [t for t in self.inner.list_tools() if not self.is_supervision_tool(t.name)]

    def servers(self) -> dict[str, McpServerConfig]:
        return self.inner.servers()

    def server_states(self) -> dict[str, ConnectionState]:
        return self.inner.server_states()

    def add_connect_listener(self, listener: ServerListener) -> None:
        self.inner.add_connect_listener(listener)

    def add_disconnect_listener(self, listener: ServerListener) -> None:
        self.inner.add_disconnect_listener(listener)

    def has_tool(self, name: str) -> bool:
        return self.inner.has_tool(name) and not self.is_supervision_tool(name)

    def set_elicitation_handler(self, handler: ElicitationHandler) -> None:
        self.inner.set_elicitation_handler(handler)

    async def start(self) -> None:
        await self.inner.start()

    async def aclose(self) -> None:
        await self.inner.aclose()
