"""Signed, single-use approvals: the proof that an operator approved exactly this call.

A destructive or teaching tool (episodic ``forget(dry_run=false)``, memory ``save_process``,
any tool a server opts in) calls :func:`require_approval` first. It reads the approval the
brain put in the request's ``_meta`` under :data:`APPROVAL_META_KEY` and accepts it only when
every check passes; otherwise it raises a tool error ``approval_required`` (none sent) or
``approval_invalid`` (sent, but one check failed — the detail names which), logged
``approval_refused``. Whoever calls: the principal's credential does not replace it.

The ``_meta`` entry (all fields required, ``v`` = 1)::

    "robot-stack/approval": {
      "v": 1,
      "server": "<the server's MCP name (serverInfo.name), the audience>",
      "tool": "<the tool's name on that server>",
      "call": "<call_digest(tool, arguments): 64 lower-case hex>",
      "approval_id": "<[A-Za-z0-9_.:-]{1,64}, unique per approval>",
      "by": "<the approving operator, 1..128 printable characters>",
      "expires": <unix seconds, integer>,
      "sig": "<64 lower-case hex>"
    }

    call_digest = sha256_hex(tool + "\\n" + json(arguments, sort_keys, separators=(",", ":")))
    key         = HMAC_SHA256(secret_utf8, b"robot-stack approval key v1")       # derived once
    message     = json([ "robot-stack/approval/v1", server, tool, call, approval_id, by,
                         expires ], separators=(",", ":"))                       # ASCII JSON
    sig         = HMAC_SHA256(key, message).hexdigest()

The secret is the server's own approval secret (``MCP_APPROVAL_SECRET`` there; the brain's
``approval_secret`` for that server), never its bearer token nor its event secret: see the
kit README ("Approvals") for why.

Checks, in order (the name is the ``check`` in the error detail and the log):
``malformed`` (shape, version, field formats), ``not_configured`` (this server has no approval
secret: it accepts none), ``bad_signature`` (constant time), ``wrong_server``, ``other_tool``,
``other_arguments`` (the digest of the arguments the server received), ``expired`` (``now >
expires + skew``), ``expiry_too_far`` (``expires > now + max_ttl + skew``: an approval lives
at most :data:`MAX_TTL_S`), ``replayed`` (this ``approval_id`` was accepted before and has not
expired yet), ``too_many`` (more unexpired approvals than the server remembers: fail closed).
An accepted approval is remembered until it expires (bounded memory), so it works once.
"""

from __future__ import annotations

import hashlib
import heapq
import hmac
import json
import re
import threading
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import structlog
from mcp.server.mcpserver.exceptions import ToolError

from robot_mcp_kit.caller import (
    APPROVAL_META_KEY,
    Approval,
    Caller,
    ToolCall,
    call_digest,
    current_caller,
)

ENV_APPROVAL_SECRET = "MCP_APPROVAL_SECRET"  # noqa: S105 - a variable's name
MIN_SECRET_BYTES = 32
APPROVAL_VERSION = 1
MAX_TTL_S = 120.0
CLOCK_SKEW_S = 5.0
MAX_REMEMBERED = 4096
KEY_LABEL = b"robot-stack approval key v1"
MESSAGE_LABEL = "robot-stack/approval/v1"
APPROVAL_REQUIRED = "approval_required"
APPROVAL_INVALID = "approval_invalid"

_APPROVAL_ID = re.compile(r"[A-Za-z0-9_.:-]{1,64}")
_HEX64 = re.compile(r"[0-9a-f]{64}")
_FIELDS = frozenset({"v", "server", "tool", "call", "approval_id", "by", "expires", "sig"})

logger = structlog.get_logger("robot_mcp_kit.approvals")


class ApprovalConfigError(ValueError):
    """The approval secret cannot be used (too short)."""


class ApprovalError(ToolError):
    """A refused approval as a tool error: ``str(err)`` is ``{"error": code, "detail": ...}``
    (the shape :func:`robot_mcp_kit.mcp_runtime.tool_error` gives)."""

    def __init__(self, code: str, check: str, detail: str) -> None:
        self.code = code
        self.check = check
        self.detail = detail
        super().__init__(json.dumps({"error": code, "detail": detail}, ensure_ascii=False))


def approval_key(secret: str | bytes) -> bytes:
    """The HMAC key approvals are signed with, derived from the approval secret with a label
    of its own (a signature made for anything else never counts as an approval)."""
    raw = secret.encode("utf-8") if isinstance(secret, str) else bytes(secret)
    if not raw:
        raise ApprovalConfigError("the approval secret is empty")
    return hmac.new(raw, KEY_LABEL, hashlib.sha256).digest()


def approval_message(
    server: str, tool: str, call: str, approval_id: str, by: str, expires: int
) -> bytes:
    """The exact bytes an approval's ``sig`` is the HMAC of (module doc)."""
    fields = [MESSAGE_LABEL, server, tool, call, approval_id, by, expires]
    return json.dumps(fields, separators=(",", ":"), ensure_ascii=True).encode("ascii")


def _signature(key: bytes, message: bytes) -> str:
    return hmac.new(key, message, hashlib.sha256).hexdigest()


def signed_approval(
    secret: str | bytes,
    *,
    server: str,
    tool: str,
    arguments: Mapping[str, Any] | None,
    approval_id: str,
    by: str,
    ttl_s: float = MAX_TTL_S,
    now: float | None = None,
) -> dict[str, Any]:
    """The ``_meta`` entry (``{APPROVAL_META_KEY: {...}}``) that proves to ``server`` that
    ``by`` approved exactly ``tool(arguments)``, valid for ``ttl_s`` (at most ``MAX_TTL_S``)."""
    if not _APPROVAL_ID.fullmatch(approval_id):
        raise ValueError(f"approval_id must match {_APPROVAL_ID.pattern}, got {approval_id!r}")
    if not _valid_by(by):
        raise ValueError("by must be 1..128 printable characters")
    expires = int((time.time() if now is None else now) + min(ttl_s, MAX_TTL_S))
    call = call_digest(tool, arguments)
    message = approval_message(server, tool, call, approval_id, by, expires)
    return {
        APPROVAL_META_KEY: {
            "v": APPROVAL_VERSION,
            "server": server,
            "tool": tool,
            "call": call,
            "approval_id": approval_id,
            "by": by,
            "expires": expires,
            "sig": _signature(approval_key(secret), message),
        }
    }


def _valid_by(by: object) -> bool:
    return isinstance(by, str) and 0 < len(by) <= 128 and by.isprintable()


@dataclass(frozen=True)
class _Claim:
    server: str
    tool: str
    call: str
    approval_id: str
    by: str
    expires: int
    sig: str


def _claim(entry: object) -> _Claim | None:
    if not isinstance(entry, Mapping) or set(entry) != _FIELDS:
        return None
    values = dict(entry)
    if values["v"] != APPROVAL_VERSION or isinstance(values["v"], bool):
        return None
    expires = values["expires"]
    if isinstance(expires, bool) or not isinstance(expires, int):
        return None
    texts = ("server", "tool", "call", "approval_id", "by", "sig")
    if not all(isinstance(values[name], str) for name in texts):
        return None
    if not (
        0 < len(values["server"]) <= 128
        and 0 < len(values["tool"]) <= 128
        and _HEX64.fullmatch(values["call"])
        and _APPROVAL_ID.fullmatch(values["approval_id"])
        and _valid_by(values["by"])
        and _HEX64.fullmatch(values["sig"])
    ):
        return None
    return _Claim(
        values["server"],
        values["tool"],
        values["call"],
        values["approval_id"],
        values["by"],
        expires,
        values["sig"],
    )


class ApprovalVerifier:
    """One server's check of the approvals it receives (thread-safe; module doc).

    ``secret`` None = this server accepts no approval (every approval-gated call is refused,
    ``not_configured``). ``clock``: unix seconds (a fake one in tests)."""

    def __init__(
        self,
        server: str,
        secret: str | bytes | None,
        *,
        max_ttl_s: float = MAX_TTL_S,
        skew_s: float = CLOCK_SKEW_S,
        max_remembered: int = MAX_REMEMBERED,
        clock: Callable[[], float] = time.time,
    ) -> None:
        if secret is not None and len(_raw(secret)) < MIN_SECRET_BYTES:
            raise ApprovalConfigError(
                f"{ENV_APPROVAL_SECRET} is {len(_raw(secret))} bytes; at least "
                f"{MIN_SECRET_BYTES} are required"
            )
        self.server = server
        self._key = approval_key(secret) if secret is not None else None
        self.max_ttl_s = max_ttl_s
        self.skew_s = skew_s
        self.max_remembered = max_remembered
        self.clock = clock
        self._used: dict[str, float] = {}  # approval_id -> expires (unix s)
        self._by_expiry: list[tuple[float, str]] = []  # a heap: the oldest expiry first
        self._lock = threading.Lock()

    @property
    def configured(self) -> bool:
        return self._key is not None

    def remembered(self) -> int:
        """How many accepted approvals are remembered now (replays of them are refused)."""
        with self._lock:
            self._forget_expired(self.clock())
            return len(self._used)

    def verify(self, entry: object, tool: str, arguments: Mapping[str, Any] | None) -> Approval:
        """Accept ``entry`` (the ``_meta`` value) for this exact call, once, or raise
        :class:`ApprovalError` naming the failed check."""
        if entry is None:
            raise ApprovalError(
                APPROVAL_REQUIRED,
                "none",
                f"{tool} needs an operator's approval of this exact call, signed by the "
                f"robot's brain (_meta {APPROVAL_META_KEY!r}); none was sent: preview it, "
                "ask the person, then call again once it is approved",
            )
        claim = _claim(entry)
        if claim is None:
            raise self._invalid(
                "malformed", f"the approval is not a version-{APPROVAL_VERSION} approval"
            )
        if self._key is None:
            raise self._invalid(
                "not_configured",
                f"this server has no approval secret ({ENV_APPROVAL_SECRET}), so it accepts "
                "no approval",
            )
        message = approval_message(
            claim.server, claim.tool, claim.call, claim.approval_id, claim.by, claim.expires
        )
        if not hmac.compare_digest(_signature(self._key, message), claim.sig):
            raise self._invalid("bad_signature", "the approval's signature does not verify")
        if claim.server != self.server:
            raise self._invalid("wrong_server", "the approval is for another server")
        if claim.tool != tool:
            raise self._invalid("other_tool", f"the approval is for {claim.tool}, not {tool}")
        if not hmac.compare_digest(claim.call, call_digest(tool, arguments)):
            raise self._invalid(
                "other_arguments", "the approval is for the same tool with other arguments"
            )
        now = self.clock()
        if now > claim.expires + self.skew_s:
            raise self._invalid("expired", f"the approval expired {now - claim.expires:.0f} s ago")
        if claim.expires > now + self.max_ttl_s + self.skew_s:
            raise self._invalid(
                "expiry_too_far",
                f"the approval claims to last beyond {self.max_ttl_s:.0f} s from now",
            )
        with self._lock:
            self._forget_expired(now)
            if claim.approval_id in self._used:
                raise self._invalid("replayed", "this approval was already used")
            if len(self._used) >= self.max_remembered:
                raise self._invalid(
                    "too_many", "too many approvals are in flight; try again in a minute"
                )
            self._used[claim.approval_id] = claim.expires
            heapq.heappush(self._by_expiry, (claim.expires, claim.approval_id))
        return Approval(claim.approval_id, claim.by)

    def _forget_expired(self, now: float) -> None:
        """Drop what expired (oldest first, O(log n) each): a replay of it is stale anyway."""
        horizon = now - self.skew_s
        while self._by_expiry and self._by_expiry[0][0] < horizon:
            _, approval_id = heapq.heappop(self._by_expiry)
            self._used.pop(approval_id, None)

    @staticmethod
    def _invalid(check: str, sentence: str) -> ApprovalError:
        return ApprovalError(APPROVAL_INVALID, check, f"approval refused ({check}): {sentence}")


def _raw(secret: str | bytes) -> bytes:
    return secret.encode("utf-8") if isinstance(secret, str) else bytes(secret)


def approval_verifier_from_env(server: str, env: Mapping[str, str]) -> ApprovalVerifier:
    """``server``'s verifier from ``MCP_APPROVAL_SECRET`` (unset = accepts no approval);
    raises :class:`ApprovalConfigError` for a secret under 32 bytes."""
    secret = env.get(ENV_APPROVAL_SECRET, "").strip()
    return ApprovalVerifier(server, secret or None)


_UNCONFIGURED = ApprovalVerifier("-", None)


def require_approval(caller: Caller | None = None) -> Approval:
    """In a tool: the verified approval of the call being served, or raise
    :class:`ApprovalError` (``approval_required`` / ``approval_invalid``), logged
    ``approval_refused`` (never the signature). The server's verifier comes from
    :func:`robot_mcp_kit.caller.install_caller_context` (``serve_mcp`` installs one from
    ``MCP_APPROVAL_SECRET``); a server without one accepts no approval."""
    who = caller or current_caller()
    call = who.call
    verifier = who.approvals
    tool = call.tool if call is not None else "this tool"
    try:
        if call is None:
            raise ApprovalVerifier._invalid("malformed", "this is not a tool call")
        approval = (verifier or _UNCONFIGURED).verify(call.approval, call.tool, call.arguments)
    except ApprovalError as refused:
        logger.warning(
            "approval_refused",
            tool=tool,
            principal=who.principal,
            error=refused.code,
            check=refused.check,
            approval_id=_claimed_id(call),
        )
        raise
    logger.info(
        "approval_accepted",
        tool=tool,
        principal=who.principal,
        approval_id=approval.approval_id,
        by=approval.by,
    )
    return approval


def _claimed_id(call: ToolCall | None) -> str | None:
    entry = call.approval if call is not None else None
    value = entry.get("approval_id") if isinstance(entry, Mapping) else None
    return value if isinstance(value, str) and _APPROVAL_ID.fullmatch(value) else None
