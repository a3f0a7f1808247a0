"""Who is calling a tool: the principal the transport proved, and the operator's approval.

**Principal.** Over sse / streamable-http, :class:`~robot_mcp_kit.service_auth.BearerAuthMiddleware`
names the credential a request presented (``brain`` or ``operator``); over stdio or in-process
the parent process is the client (``local``); an HTTP server run with ``MCP_AUTH=off`` knows no
one (``anonymous``).

**Approval.** When an operator approved a call, the brain sends the approval in the request's
``_meta`` under :data:`APPROVAL_META_KEY`: ``{"approval_id", "by", "call"}``, ``call`` being
:func:`call_digest` of the tool name and its exact arguments. It counts only for that call: the
server recomputes the digest from the request it got.

:class:`CallerContext` (a server middleware installed by ``serve_mcp`` and by servers whose
tools ask) makes both available to the tool as :func:`current_caller`. Servers decide what
they demand: episodic's ``forget`` deletes only for the brain (or a local parent) with an
approval.
"""

from __future__ import annotations

import hashlib
import json
import re
from collections.abc import Mapping
from contextvars import ContextVar
from dataclasses import dataclass
from typing import Any

from mcp.server.context import CallNext, HandlerResult, ServerRequestContext
from mcp.server.mcpserver import MCPServer

BRAIN = "brain"
OPERATOR = "operator"
LOCAL = "local"
ANONYMOUS = "anonymous"
PRINCIPAL_SCOPE_KEY = "robot_stack.principal"
APPROVAL_META_KEY = "robot-stack/approval"
_APPROVAL_ID = re.compile(r"^[A-Za-z0-9_.:-]{1,64}$")


@dataclass(frozen=True)
class Approval:
    approval_id: str
    by: str  # the operator who approved


@dataclass(frozen=True)
class Caller:
    principal: str
    approval: Approval | None = None


_current: ContextVar[Caller | None] = ContextVar("current_caller", default=None)


def current_caller() -> Caller:
    """The caller of the tool call this code runs for (``local``, no approval, outside one)."""
    return _current.get() or Caller(LOCAL)


def call_digest(tool: str, arguments: Mapping[str, Any] | None) -> str:
    """sha256 of the tool name and its canonical JSON arguments (what an approval binds)."""
    text = f"{tool}\n{json.dumps(dict(arguments or {}), sort_keys=True, separators=(',', ':'))}"
    return hashlib.sha256(text.encode()).hexdigest()


def approval_meta(
    tool: str, arguments: Mapping[str, Any], approval_id: str, by: str
) -> dict[str, Any]:
    """The ``_meta`` entry that tells the server an operator approved exactly this call."""
    return {
        APPROVAL_META_KEY: {
            "approval_id": approval_id,
            "by": by,
            "call": call_digest(tool, arguments),
        }
    }


def approval_from(
    meta: Mapping[str, Any] | None, tool: str, arguments: Mapping[str, Any] | None
) -> Approval | None:
    """The approval in a request's ``_meta`` when it is for exactly this call, else None."""
    value = (meta or {}).get(APPROVAL_META_KEY)
    if not isinstance(value, Mapping):
        return None
    approval_id, by, digest = value.get("approval_id"), value.get("by"), value.get("call")
    if not (isinstance(approval_id, str) and _APPROVAL_ID.match(approval_id)):
        return None
    if not (isinstance(by, str) and 0 < len(by) <= 128 and by.isprintable()):
        return None
    if digest != call_digest(tool, arguments):
        return None
    return Approval(str(approval_id), str(by))


def principal_of(request: Any) -> str:
    """The principal the transport put on the request's ASGI scope (see module doc)."""
    if request is None:
        return LOCAL
    scope = getattr(request, "scope", None)
    principal = scope.get(PRINCIPAL_SCOPE_KEY) if isinstance(scope, Mapping) else None
    return principal if isinstance(principal, str) else ANONYMOUS


class CallerContext:
    """Server middleware: binds :func:`current_caller` for the whole request."""

    async def __call__(
        self, ctx: ServerRequestContext[Any, Any], call_next: CallNext
    ) -> HandlerResult:
        approval = None
        if ctx.method == "tools/call":
            params = ctx.params or {}
            arguments = params.get("arguments")
            approval = approval_from(
                ctx.meta,
                str(params.get("name", "")),
                arguments if isinstance(arguments, Mapping) else None,
            )
        token = _current.set(Caller(principal_of(ctx.request), approval))
        try:
            return await call_next(ctx)
        finally:
            _current.reset(token)


def install_caller_context(server: MCPServer) -> MCPServer:
    """Add :class:`CallerContext` to ``server`` (once); returns the server."""
    if not any(isinstance(m, CallerContext) for m in server.middleware):
        server.middleware.append(CallerContext())
    return server
