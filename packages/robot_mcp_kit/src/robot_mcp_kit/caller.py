"""Who is calling a tool: the principal the transport proved, and the call it made.

**Principal.** Over sse / streamable-http, :class:`~robot_mcp_kit.service_auth.BearerAuthMiddleware`
names the credential a request presented (``brain`` or ``operator``); over stdio or in-process
the parent process is the client (``local``); an HTTP server run with ``MCP_AUTH=off`` knows no
one (``anonymous``).

**Approval.** When an operator approved a call, the brain sends a signed approval in the
request's ``_meta`` under :data:`APPROVAL_META_KEY` (format and checks:
:mod:`robot_mcp_kit.approvals`). :class:`CallerContext` keeps it, unverified, with the tool's
name and arguments (:class:`ToolCall`); a tool that needs one calls
:func:`robot_mcp_kit.approvals.require_approval`, which verifies it — once — with the verifier
the server installed. Nothing else ever reads an unverified approval.

:class:`CallerContext` (a server middleware installed by ``serve_mcp`` and by servers whose
tools ask) makes both available to the tool as :func:`current_caller`.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping
from contextvars import ContextVar
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from mcp.server.context import CallNext, HandlerResult, ServerRequestContext
from mcp.server.mcpserver import MCPServer

if TYPE_CHECKING:
    from robot_mcp_kit.approvals import ApprovalVerifier

BRAIN = "brain"
OPERATOR = "operator"
LOCAL = "local"
ANONYMOUS = "anonymous"
PRINCIPAL_SCOPE_KEY = "robot_stack.principal"
APPROVAL_META_KEY = "robot-stack/approval"


@dataclass(frozen=True)
class Approval:
    """A verified approval: who approved (``by``) under which id."""

    approval_id: str
    by: str  # the operator who approved


@dataclass(frozen=True)
class ToolCall:
    """The ``tools/call`` being served: the tool, its arguments, and the approval entry the
    request carried in ``_meta`` (unverified; None when none)."""

    tool: str
    arguments: Mapping[str, Any] | None
    approval: Any = None


@dataclass(frozen=True)
class Caller:
    principal: str
    call: ToolCall | None = None
    approvals: ApprovalVerifier | None = None
    """The server's approval check (:func:`install_caller_context`); None = accepts none."""


_current: ContextVar[Caller | None] = ContextVar("current_caller", default=None)


def current_caller() -> Caller:
    """The caller of the tool call this code runs for (``local``, no call, outside one)."""
    return _current.get() or Caller(LOCAL)


def call_digest(tool: str, arguments: Mapping[str, Any] | None) -> str:
    """sha256 of the tool name and its canonical JSON arguments (what an approval binds)."""
    text = f"{tool}\n{json.dumps(dict(arguments or {}), sort_keys=True, separators=(',', ':'))}"
    return hashlib.sha256(text.encode()).hexdigest()


def principal_of(request: Any) -> str:
    """The principal the transport put on the request's ASGI scope (see module doc)."""
    if request is None:
        return LOCAL
    scope = getattr(request, "scope", None)
    principal = scope.get(PRINCIPAL_SCOPE_KEY) if isinstance(scope, Mapping) else None
    return principal if isinstance(principal, str) else ANONYMOUS


class CallerContext:
    """Server middleware: binds :func:`current_caller` for the whole request."""

    def __init__(self, approvals: ApprovalVerifier | None = None) -> None:
        self.approvals = approvals

    async def __call__(
        self, ctx: ServerRequestContext[Any, Any], call_next: CallNext
    ) -> HandlerResult:
        call = None
        if ctx.method == "tools/call":
            params = ctx.params or {}
            arguments = params.get("arguments")
            call = ToolCall(
                str(params.get("name", "")),
                arguments if isinstance(arguments, Mapping) else None,
                (ctx.meta or {}).get(APPROVAL_META_KEY),
            )
        token = _current.set(Caller(principal_of(ctx.request), call, self.approvals))
        try:
            return await call_next(ctx)
        finally:
            _current.reset(token)


def install_caller_context(
    server: MCPServer, approvals: ApprovalVerifier | None = None
) -> MCPServer:
    """Add :class:`CallerContext` to ``server`` (once); ``approvals``, when given, becomes its
    approval check (replacing an earlier one). Returns the server."""
    for middleware in server.middleware:
        if isinstance(middleware, CallerContext):
            if approvals is not None:
                middleware.approvals = approvals
            return server
    server.middleware.append(CallerContext(approvals))
    return server
