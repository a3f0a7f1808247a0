import json
from pathlib import Path
from typing import Any

import pytest
from mcp import Client

from robot_mcp_memory.composition import build_memory
from robot_mcp_memory.config import MemoryConfig
from robot_mcp_memory.documents import FORMAT_SPEC
from robot_mcp_memory.service import ProcessMemory
from robot_mcp_memory.store.base import StoreError
from robot_mcp_memory.store.fake import FakeProcessStore
from robot_mcp_memory.tools import build_server


async def call(client: Client, tool: str, **arguments: Any) -> tuple[bool, dict[str, Any]]:
    result = await client.call_tool(tool, arguments)
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
