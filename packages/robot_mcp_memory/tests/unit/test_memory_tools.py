import json
from pathlib import Path
from typing import Any, cast

import pytest
from mcp import Client
from mcp.server.mcpserver import MCPServer
from mcp.types import RequestParamsMeta

from robot_mcp_kit.approvals import ApprovalVerifier
from robot_mcp_memory.composition import build_memory
from robot_mcp_memory.config import MemoryConfig
from robot_mcp_memory.documents import FORMAT_SPEC
from robot_mcp_memory.service import ProcessMemory
from robot_mcp_memory.store.base import StoreError
from robot_mcp_memory.store.fake import FakeProcessStore
from robot_mcp_memory.tools import build_server as build_bare_server
from robot_stack_testing.kit.tool_calls import approved

APPROVALS = "memory-approval-secret-of-the-unit-tests"


def build_server(memory: ProcessMemory) -> MCPServer:
    """The server as ``serve_mcp`` runs it with ``MCP_APPROVAL_SECRET`` set."""
    return build_bare_server(memory, ApprovalVerifier("memory", APPROVALS))


async def call(client: Client, tool: str, **arguments: Any) -> tuple[bool, dict[str, Any]]:
    """A tool call; ``save_process`` as the brain sends it after an operator's yes."""
    meta = approved(APPROVALS, "memory", tool, arguments) if tool == "save_process" else None
    result = await client.call_tool(
        tool, arguments, meta=cast(RequestParamsMeta, meta) if meta is not None else None
    )
    (block,) = result.content
    assert block.type == "text"
    return bool(result.is_error), json.loads(block.text)


@pytest.fixture
def memory(tmp_path: Path) -> ProcessMemory:
    return build_memory(MemoryConfig(db_path=tmp_path / "memory.sqlite3", robot_id="mailbot"))


async def test_the_server_is_named_memory_and_lists_its_five_tools(memory: ProcessMemory) -> None:
    async with Client(build_server(memory)) as client:
        tools = {tool.name: tool for tool in (await client.list_tools()).tools}

    assert set(tools) == {
        "find_processes",
        "save_process",
        "record_outcome",
        "get_process",
        "list_processes",
    }
    assert FORMAT_SPEC in (tools["save_process"].description or "")
    assert "version" in (tools["save_process"].description or "")
    assert (tools["find_processes"].description or "").startswith("Call this")
    assert tools["find_processes"].input_schema["properties"]["k"]["default"] == 3


async def test_a_teaching_round_trip_over_mcp(memory: ProcessMemory, docs: Any) -> None:
    async with Client(build_server(memory)) as client:
        for markdown in docs.all():
            error, saved = await call(client, "save_process", markdown=markdown)
            assert not error, saved
        error, found = await call(
            client, "find_processes", query="fetch the package from the mail room", k=2
        )
        _, recorded = await call(
            client, "record_outcome", process_id=found["results"][0]["id"], success=True, note="ok"
        )
        _, listed = await call(client, "list_processes")
        _, got = await call(client, "get_process", id="fetch-package-from-mailroom")

    assert not error
    assert found["results"][0]["id"] == "fetch-package-from-mailroom"
    assert len(found["results"]) == 2
    assert recorded["successes"] == 1
    assert listed["total"] == 5
    assert listed["robot_id"] == "mailbot"
    assert got["recent_outcomes"][0]["note"] == "ok"


async def test_tool_errors_are_json_the_model_can_read(memory: ProcessMemory) -> None:
    async with Client(build_server(memory)) as client:
        bad_doc = await call(client, "save_process", markdown="## Steps\n1. go")
        missing = await call(client, "get_process", id="nope", version=2)
        bad_k = await call(client, "find_processes", query="x", k=99)

    assert bad_doc[0] is True
    assert bad_doc[1]["error"] == "invalid_document"
    assert "missing YAML frontmatter" in bad_doc[1]["detail"]
    assert missing == (
        True,
        {
            "error": "not_found",
            "detail": "no process 'nope' version 2 visible to robot 'mailbot' (robot visibility); "
            "call list_processes or "
            "find_processes to see which ids exist",
        },
    )
    assert bad_k[0] is True
    assert bad_k[1]["error"] == "tool_error"


async def test_an_unexpected_failure_is_an_internal_error_not_a_crash() -> None:
    store = FakeProcessStore()
    store.fail_with = RuntimeError("boom")
    server = build_server(ProcessMemory(store))

    async with Client(server) as client:
        error, body = await call(client, "list_processes")
        store.fail_with = StoreError("locked")
        unavailable = await call(client, "list_processes")

    assert error is True
    assert body == {
        "error": "internal_error",
        "detail": "list_processes failed unexpectedly; the server logged the cause",
    }
    assert unavailable[1]["error"] == "store_unavailable"


async def test_save_process_without_a_valid_approval_stores_nothing(
    memory: ProcessMemory, docs: Any
) -> None:
    args = {"markdown": docs.escort}
    genuine = approved(APPROVALS, "memory", "save_process", args)
    key = next(iter(genuine))
    forged = {key: {**genuine[key], "by": "mallory"}}
    other = approved(APPROVALS, "memory", "save_process", {"markdown": docs.plants})
    async with Client(build_server(memory)) as client:
        answers = [
            await client.call_tool("save_process", args, meta=cast(RequestParamsMeta, meta))
            for meta in (None, forged, other)
        ]
        listed = await call(client, "list_processes")
    codes = [json.loads(a.content[0].text)["error"] for a in answers]  # type: ignore[union-attr]
    assert codes == ["approval_required", "approval_invalid", "approval_invalid"]
    assert listed[1]["total"] == 0


async def test_a_memory_server_without_an_approval_secret_stores_nothing(
    memory: ProcessMemory, docs: Any
) -> None:
    args = {"markdown": docs.escort}
    async with Client(build_bare_server(memory)) as client:
        signed = approved(APPROVALS, "memory", "save_process", args)
        answer = await client.call_tool("save_process", args, meta=cast(RequestParamsMeta, signed))
        _, listed = await call(client, "list_processes")
    assert json.loads(answer.content[0].text)["error"] == "approval_invalid"  # type: ignore[union-attr]
    assert listed["total"] == 0
