"""Who calls a tool: the principal and an operator's approval bound to the exact call."""

from __future__ import annotations

from typing import Any, cast

from mcp import Client
from mcp.server.mcpserver import MCPServer
from mcp.types import RequestParamsMeta

from robot_mcp_kit.caller import (
    APPROVAL_META_KEY,
    Approval,
    CallerContext,
    approval_from,
    approval_meta,
    call_digest,
    current_caller,
    install_caller_context,
    principal_of,
)


def build() -> MCPServer:
    server = MCPServer("caller-test")

    @server.tool()
    async def erase(start: str, dry_run: bool = True) -> dict[str, Any]:
        """Reports who called."""
        caller = current_caller()
        approval = caller.approval
        return {
            "principal": caller.principal,
            "approved_by": approval.by if approval is not None else None,
        }

    return install_caller_context(install_caller_context(server))  # installing twice is once


def meta(value: dict[str, Any]) -> RequestParamsMeta:
    return cast(RequestParamsMeta, value)


async def test_an_in_process_client_is_the_local_parent_and_brings_no_approval() -> None:
    server = build()
    assert sum(isinstance(m, CallerContext) for m in server.middleware) == 1
    async with Client(server) as client:
        answer = await client.call_tool("erase", {"start": "-1h"})
    assert answer.structured_content == {"principal": "local", "approved_by": None}


async def test_an_approval_counts_only_for_the_exact_call_it_names() -> None:
    approved = {"start": "-1h", "dry_run": False}
    async with Client(build()) as client:
        same = await client.call_tool(
            "erase", approved, meta=meta(approval_meta("erase", approved, "ap-1", "alice"))
        )
        other = await client.call_tool(
            "erase",
            {"start": "-36500d", "dry_run": False},
            meta=meta(approval_meta("erase", approved, "ap-1", "alice")),
        )
    assert same.structured_content == {"principal": "local", "approved_by": "alice"}
    assert other.structured_content == {"principal": "local", "approved_by": None}


def test_the_digest_binds_the_tool_and_the_canonical_arguments() -> None:
    assert call_digest("erase", {"a": 1, "b": 2}) == call_digest("erase", {"b": 2, "a": 1})
    assert call_digest("erase", {"a": 1}) != call_digest("forget", {"a": 1})
    assert call_digest("erase", {"a": 1}) != call_digest("erase", {"a": 2})
    assert call_digest("erase", None) == call_digest("erase", {})


def test_malformed_approvals_are_no_approval() -> None:
    good = approval_meta("erase", {}, "ap-1", "local operator (no login)")
    assert approval_from(good, "erase", {}) == Approval("ap-1", "local operator (no login)")
    entry = good[APPROVAL_META_KEY]
    for broken in (
        {**entry, "approval_id": "ap 1; drop"},
        {**entry, "by": ""},
        {**entry, "by": "x" * 129},
        {**entry, "by": "alice\nforged log line"},
        {**entry, "call": "0" * 64},
        {k: v for k, v in entry.items() if k != "by"},
    ):
        assert approval_from({APPROVAL_META_KEY: broken}, "erase", {}) is None
    assert approval_from({APPROVAL_META_KEY: "yes"}, "erase", {}) is None
    assert approval_from(None, "erase", {}) is None


class _Request:
    def __init__(self, scope: dict[str, Any]) -> None:
        self.scope = scope


def test_the_principal_comes_from_the_transport_scope() -> None:
    assert principal_of(None) == "local"  # stdio / in-process: the parent is the client
    assert principal_of(_Request({"robot_stack.principal": "brain"})) == "brain"
    assert principal_of(_Request({})) == "anonymous"  # HTTP with MCP_AUTH=off
    assert current_caller().principal == "local"  # outside a call
