"""Signed, single-use approvals (issue 35 item 4): a made-up, replayed, re-targeted or stale
approval opens nothing, whoever sends it."""

from __future__ import annotations

import json
from typing import Any, cast

import pytest
from mcp import Client
from mcp.server.mcpserver import MCPServer
from mcp.types import RequestParamsMeta

from robot_mcp_kit.approvals import (
    APPROVAL_INVALID,
    APPROVAL_REQUIRED,
    ApprovalConfigError,
    ApprovalError,
    ApprovalVerifier,
    approval_verifier_from_env,
    require_approval,
    signed_approval,
)
from robot_mcp_kit.caller import APPROVAL_META_KEY, install_caller_context
from robot_mcp_kit.mcp_runtime import install_json_tool_errors, transport_settings
from robot_mcp_kit.signing import sign
from robot_stack_testing import approval_meta as outside_approval

SECRET = "approval-secret-of-the-test-server-0123456789"
OTHER_SECRET = "approval-secret-of-another-server-9876543210"
SERVER = "vault"
NOW = 1_800_000_000.0


class FakeClock:
    def __init__(self, now: float = NOW) -> None:
        self.now = now

    def __call__(self) -> float:
        return self.now


def build(verifier: ApprovalVerifier | None) -> tuple[MCPServer, list[dict[str, Any]]]:
    """A server whose ``erase`` deletes (records) only with a verified approval."""
    server = MCPServer(SERVER)
    erased: list[dict[str, Any]] = []

    @server.tool()
    async def erase(start: str, dry_run: bool = True) -> dict[str, Any]:
        """Erases from start (records the erasure)."""
        approval = require_approval()
        erased.append({"start": start, "by": approval.by})
        return {"erased": start, "by": approval.by}

    install_json_tool_errors(server)
    return install_caller_context(server, verifier), erased


def approve(
    arguments: dict[str, Any],
    *,
    secret: str = SECRET,
    server: str = SERVER,
    tool: str = "erase",
    approval_id: str = "ap-0123456789ab",
    by: str = "alice",
    now: float = NOW,
    ttl_s: float = 120.0,
) -> RequestParamsMeta:
    entry = signed_approval(
        secret,
        server=server,
        tool=tool,
        arguments=arguments,
        approval_id=approval_id,
        by=by,
        ttl_s=ttl_s,
        now=now,
    )
    return cast(RequestParamsMeta, entry)


async def call(
    server: MCPServer, arguments: dict[str, Any], meta: RequestParamsMeta | None
) -> dict[str, Any]:
    async with Client(server) as client:
        result = await client.call_tool("erase", arguments, meta=meta)
    payload: dict[str, Any] = json.loads(result.content[0].text)  # type: ignore[union-attr]
    return {"_error": payload} if result.is_error else payload


ARGS = {"start": "-1h", "dry_run": False}


async def test_a_signed_approval_of_this_exact_call_works_once() -> None:
    server, erased = build(ApprovalVerifier(SERVER, SECRET, clock=FakeClock()))
    meta = approve(ARGS)
    assert await call(server, ARGS, meta) == {"erased": "-1h", "by": "alice"}
    replayed = await call(server, ARGS, meta)
    assert replayed["_error"]["error"] == APPROVAL_INVALID
    assert "(replayed)" in replayed["_error"]["detail"]
    assert erased == [{"start": "-1h", "by": "alice"}]  # done once


def _entry(meta: RequestParamsMeta) -> dict[str, Any]:
    value: dict[str, Any] = dict(meta)[APPROVAL_META_KEY]
    return value


def _forged(**changes: Any) -> RequestParamsMeta:
    return cast(RequestParamsMeta, {APPROVAL_META_KEY: {**_entry(approve(ARGS)), **changes}})


REFUSED = [
    ("no approval", None, APPROVAL_REQUIRED, "none was sent"),
    (
        "issue 27's unsigned approval",
        cast(
            RequestParamsMeta,
            {APPROVAL_META_KEY: {"approval_id": "ap-1", "by": "mallory", "call": "0" * 64}},
        ),
        APPROVAL_INVALID,
        "(malformed)",
    ),
    ("a made-up approver", _forged(by="mallory"), APPROVAL_INVALID, "(bad_signature)"),
    ("another key", approve(ARGS, secret=OTHER_SECRET), APPROVAL_INVALID, "(bad_signature)"),
    ("a zero signature", _forged(sig="0" * 64), APPROVAL_INVALID, "(bad_signature)"),
    (
        "an event signature",
        _forged(sig=sign(SECRET, int(NOW), b"{}").removeprefix("sha256=")),
        APPROVAL_INVALID,
        "(bad_signature)",
    ),
    ("another server", approve(ARGS, server="memory"), APPROVAL_INVALID, "(wrong_server)"),
    ("another tool", approve(ARGS, tool="purge"), APPROVAL_INVALID, "(other_tool)"),
    (
        "other arguments",
        approve({"start": "-36500d", "dry_run": False}),
        APPROVAL_INVALID,
        "(other_arguments)",
    ),
    ("an expired one", approve(ARGS, now=NOW - 200), APPROVAL_INVALID, "(expired)"),
    ("one for an hour", approve(ARGS, now=NOW + 3600), APPROVAL_INVALID, "(expiry_too_far)"),
    ("version 2", _forged(v=2), APPROVAL_INVALID, "(malformed)"),
    ("a string expiry", _forged(expires=str(int(NOW) + 60)), APPROVAL_INVALID, "(malformed)"),
    ("an odd id", _forged(approval_id="ap 1; drop"), APPROVAL_INVALID, "(malformed)"),
    ("a newline approver", _forged(by="alice\nforged"), APPROVAL_INVALID, "(malformed)"),
    ("an extra field", _forged(scope="all"), APPROVAL_INVALID, "(malformed)"),
    ("not an object", cast(RequestParamsMeta, {APPROVAL_META_KEY: "yes"}), APPROVAL_INVALID, ""),
]


@pytest.mark.parametrize(
    ("meta", "code", "check"), [r[1:] for r in REFUSED], ids=[r[0] for r in REFUSED]
)
async def test_anything_but_a_valid_approval_is_refused_and_erases_nothing(
    meta: RequestParamsMeta | None, code: str, check: str
) -> None:
    server, erased = build(ApprovalVerifier(SERVER, SECRET, clock=FakeClock()))
    refused = await call(server, ARGS, meta)
    assert refused["_error"]["error"] == code
    assert check in refused["_error"]["detail"]
    assert SECRET not in json.dumps(refused)
    assert erased == []


async def test_a_server_without_an_approval_secret_accepts_none() -> None:
    for verifier in (None, ApprovalVerifier(SERVER, None)):
        server, erased = build(verifier)
        refused = await call(server, ARGS, approve(ARGS))
        assert refused["_error"]["error"] == APPROVAL_INVALID
        assert "(not_configured)" in refused["_error"]["detail"]
        assert (await call(server, ARGS, None))["_error"]["error"] == APPROVAL_REQUIRED
        assert erased == []


def test_the_clock_skew_is_small_and_an_accepted_approval_is_forgotten_once_expired() -> None:
    clock = FakeClock()
    verifier = ApprovalVerifier(SERVER, SECRET, clock=clock, skew_s=5)
    entry = _entry(approve(ARGS, ttl_s=60))
    clock.now = NOW + 64  # 4 s past expiry: within the skew
    assert verifier.verify(entry, "erase", ARGS).by == "alice"
    assert verifier.remembered() == 1
    clock.now = NOW + 66
    assert verifier.remembered() == 0  # bounded: expired ids are dropped...
    with pytest.raises(ApprovalError) as stale:  # ...and the approval itself is stale
        verifier.verify(entry, "erase", ARGS)
    assert stale.value.check == "expired"


def test_memory_is_bounded_and_full_means_refused_not_forgotten() -> None:
    verifier = ApprovalVerifier(SERVER, SECRET, clock=FakeClock(), max_remembered=2)
    entries = [_entry(approve(ARGS, approval_id=f"ap-{n}")) for n in range(3)]
    verifier.verify(entries[0], "erase", ARGS)
    verifier.verify(entries[1], "erase", ARGS)
    with pytest.raises(ApprovalError) as full:
        verifier.verify(entries[2], "erase", ARGS)
    assert full.value.check == "too_many"
    with pytest.raises(ApprovalError) as replay:
        verifier.verify(entries[0], "erase", ARGS)  # still remembered: still refused
    assert replay.value.check == "replayed"


def test_the_readme_recipe_written_elsewhere_verifies() -> None:
    """robot_stack_testing signs from the README's recipe, not the kit's code."""
    verifier = ApprovalVerifier(SERVER, SECRET, clock=FakeClock())
    meta = outside_approval(
        SECRET,
        server=SERVER,
        tool="erase",
        arguments=ARGS,
        approval_id="ap-outside",
        by="bob",
        expires=int(NOW) + 30,
    )
    assert verifier.verify(meta[APPROVAL_META_KEY], "erase", ARGS).by == "bob"


def test_the_secret_must_be_long_and_comes_from_the_environment() -> None:
    with pytest.raises(ApprovalConfigError, match="at least 32"):
        ApprovalVerifier(SERVER, "short")
    assert approval_verifier_from_env(SERVER, {}).configured is False
    assert approval_verifier_from_env(SERVER, {"MCP_APPROVAL_SECRET": SECRET}).configured
    with pytest.raises(ValueError, match="MCP_APPROVAL_SECRET is 5 bytes"):
        transport_settings({"MCP_APPROVAL_SECRET": "short"}, 9000)
    settings = transport_settings({"MCP_APPROVAL_SECRET": SECRET}, 9000)
    assert settings.approval_secret is not None
    assert SECRET not in repr(settings)


def test_signing_refuses_what_no_server_would_accept() -> None:
    with pytest.raises(ValueError, match="approval_id"):
        approve(ARGS, approval_id="ap 1")
    with pytest.raises(ValueError, match="printable"):
        approve(ARGS, by="")
    entry = _entry(approve(ARGS, ttl_s=3600))
    assert entry["expires"] == int(NOW) + 120  # capped at the longest life a server accepts
