"""Who calls a tool: the principal and the call (an approval is verified by
``robot_mcp_kit.approvals``: test_kit_approvals.py)."""

from __future__ import annotations

from typing import Any, cast

from mcp import Client
from mcp.server.mcpserver import MCPServer
from mcp.types import RequestParamsMeta

from robot_mcp_kit.caller import (
    APPROVAL_META_KEY,
    CallerContext,
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
        call = caller.call
        assert call is not None
        return {
            "principal": caller.principal,
            "tool": call.tool,
            "arguments": dict(call.arguments or {}),
            "sent_approval": call.approval,
        }

    return install_caller_context(install_caller_context(server))  # installing twice is once


def meta(value: dict[str, Any]) -> RequestParamsMeta:
    return cast(RequestParamsMeta, value)


async def test_an_in_process_client_is_the_local_parent_and_brings_no_approval() -> None:
    server = build()
    assert sum(isinstance(m, CallerContext) for m in server.middleware) == 1
    async with Client(server) as client:
        answer = await client.call_tool("erase", {"start": "-1h"})
    assert answer.structured_content == {
        "principal": "local",
        "tool": "erase",
        "arguments": {"start": "-1h"},
        "sent_approval": None,
    }


async def test_the_approval_a_request_carries_reaches_the_tool_only_as_unverified_data() -> None:
    sent = {"approval_id": "ap-1", "by": "mallory", "call": "0" * 64}
    async with Client(build()) as client:
        answer = await client.call_tool(
            "erase", {"start": "-1h"}, meta=meta({APPROVAL_META_KEY: sent})
        )
    content = answer.structured_content
    assert content is not None
    assert content["sent_approval"] == sent  # raw: only require_approval() turns it into one
    assert current_caller().call is None  # outside a call


def test_the_digest_binds_the_tool_and_the_canonical_arguments() -> None:
    assert call_digest("erase", {"a": 1, "b": 2}) == call_digest("erase", {"b": 2, "a": 1})
    assert call_digest("erase", {"a": 1}) != call_digest("forget", {"a": 1})
    assert call_digest("erase", {"a": 1}) != call_digest("erase", {"a": 2})
    assert call_digest("erase", None) == call_digest("erase", {})


class _Request:
    def __init__(self, scope: dict[str, Any]) -> None:
        self.scope = scope


def test_the_principal_comes_from_the_transport_scope() -> None:
    assert principal_of(None) == "local"  # stdio / in-process: the parent is the client
    assert principal_of(_Request({"robot_stack.principal": "brain"})) == "brain"
    assert principal_of(_Request({})) == "anonymous"  # HTTP with MCP_AUTH=off
    assert current_caller().principal == "local"  # outside a call
