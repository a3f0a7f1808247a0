"""The real ``robot-mcp-memory`` process, driven by a real MCP client over each transport."""

import asyncio
import json
import sys
from pathlib import Path
from typing import Any

import pytest
from mcp import Client
from mcp.client.stdio import StdioServerParameters

from robot_stack_testing import (
    LaunchedProcess,
    ProcessLauncher,
    assert_refuses_strangers,
    fresh_token,
    mcp_transport,
    wait_for_tcp_port,
)

TOKEN = fresh_token()  # the server's MCP_AUTH_TOKEN
SERVER = str(Path(sys.executable).parent / "robot-mcp-memory")
QUERY = "could someone bring me the parcel that arrived"


def start_server(
    launcher: ProcessLauncher, db: Path, transport: str, port: int, robot_id: str = "mailbot"
) -> LaunchedProcess:
    process = launcher.start(
        f"memory-{transport}",
        [SERVER],
        env={
            "MCP_TRANSPORT": transport,
            "MCP_AUTH_TOKEN": TOKEN,
            "MCP_PORT": str(port),
            "MEMORY_DB": str(db),
            "ROBOT_ID": robot_id,
        },
    )
    try:
        wait_for_tcp_port(port, timeout_s=30)
    except TimeoutError:
        pytest.fail(f"memory server did not listen on {port}:\n{process.log()}")
    return process


async def call(client: Client, tool: str, **arguments: Any) -> tuple[bool, dict[str, Any]]:
    result = await client.call_tool(tool, arguments, read_timeout_seconds=30)
    (block,) = result.content
    assert block.type == "text"
    return bool(result.is_error), json.loads(block.text)


async def ranked_ids(client: Client, query: str) -> list[str]:
    error, found = await call(client, "find_processes", query=query, k=3)
    assert not error, found
    return [result["id"] for result in found["results"]]


async def test_save_find_outcome_and_rejection_over_streamable_http(
    launcher: ProcessLauncher, tcp_port: int, tmp_path: Path, docs: Any
) -> None:
    start_server(launcher, tmp_path / "memory.sqlite3", "streamable-http", tcp_port)
    # nobody without the server's credential gets in (issue 27)
    await asyncio.to_thread(assert_refuses_strangers, f"http://127.0.0.1:{tcp_port}/mcp", "memory")

    async with Client(
        mcp_transport(f"http://127.0.0.1:{tcp_port}/mcp", TOKEN), read_timeout_seconds=30
    ) as client:
        for markdown in docs.all():
            error, saved = await call(client, "save_process", markdown=markdown)
            assert not error, saved
        before = await ranked_ids(client, QUERY)
        for _ in range(4):
            error, _ = await call(
                client, "record_outcome", process_id=before[0], success=False, note="wrong room"
            )
            assert not error
        await call(client, "record_outcome", process_id=before[1], success=True, note="worked")
        after = await ranked_ids(client, QUERY)
        bad_id = await call(
            client,
            "save_process",
            markdown=docs.plants.replace("id: water-office-plants", "id: Water Plants!"),
        )
        no_steps = await call(
            client, "save_process", markdown=docs.plants.replace("## Steps", "## Procedure")
        )

    assert set(before[:2]) == {"collect-parcel-at-reception", "fetch-package-from-mailroom"}
    assert after[:2] == [before[1], before[0]]
    assert bad_id[0] is True
    assert bad_id[1]["error"] == "invalid_document"
    assert "frontmatter field 'id' ('Water Plants!') must be a slug" in bad_id[1]["detail"]
    assert no_steps[1] == {
        "error": "invalid_document",
        "detail": "the process document was not saved: missing section '## Steps'. "
        "Fix these and call save_process again with the whole document.",
    }


async def test_versions_and_outcomes_survive_a_restart_over_sse(
    launcher: ProcessLauncher, tcp_port: int, tmp_path: Path, docs: Any
) -> None:
    db = tmp_path / "memory.sqlite3"
    first = start_server(launcher, db, "sse", tcp_port)
    async with Client(mcp_transport(f"http://127.0.0.1:{tcp_port}/sse", TOKEN)) as client:
        await call(client, "save_process", markdown=docs.mailroom)
        error, second = await call(
            client, "save_process", markdown=docs.mailroom.replace("desk 4", "desk 6")
        )
        await call(
            client,
            "record_outcome",
            process_id="fetch-package-from-mailroom",
            success=True,
            note="fine",
        )
    assert not error
    assert second["version"] == 2
    launcher.stop(first)

    start_server(launcher, db, "sse", tcp_port)
    async with Client(mcp_transport(f"http://127.0.0.1:{tcp_port}/sse", TOKEN)) as client:
        _, current = await call(client, "get_process", id="fetch-package-from-mailroom")
        _, old = await call(client, "get_process", id="fetch-package-from-mailroom", version=1)
        found = await ranked_ids(client, "parcel in the post room")

    assert (current["version"], current["successes"]) == (2, 1)
    assert "desk 6" in current["markdown"]
    assert "desk 4" in old["markdown"]
    assert found == ["fetch-package-from-mailroom"]


async def test_the_stdio_transport_serves_the_same_tools_scoped_by_robot(
    tmp_path: Path, docs: Any
) -> None:
    db = tmp_path / "memory.sqlite3"

    def stdio(robot_id: str) -> StdioServerParameters:
        return StdioServerParameters(
            command=SERVER,
            env={"MCP_TRANSPORT": "stdio", "MEMORY_DB": str(db), "ROBOT_ID": robot_id},
        )

    async with Client(stdio("robot-a"), read_timeout_seconds=30) as client:
        error, saved = await call(client, "save_process", markdown=docs.escort)
    async with Client(stdio("robot-b"), read_timeout_seconds=30) as client:
        _, listed_b = await call(client, "list_processes")
        missing = await call(client, "get_process", id="escort-visitor-to-meeting-room")
    async with Client(stdio("robot-a"), read_timeout_seconds=30) as client:
        found = await ranked_ids(client, "accompany a guest to the conference room")

    assert not error, saved
    assert listed_b["total"] == 0
    assert missing[1]["error"] == "not_found"
    assert found == ["escort-visitor-to-meeting-room"]


def test_an_invalid_setting_stops_the_server_with_a_clear_log_line(
    launcher: ProcessLauncher, tmp_path: Path
) -> None:
    process = launcher.start(
        "memory-bad-config",
        [SERVER],
        env={"MEMORY_OUTCOME_WEIGHT": "7", "MEMORY_DB": str(tmp_path / "m.sqlite3")},
    )

    assert process.popen.wait(timeout=30) == 2
    lines = [json.loads(line) for line in process.log().splitlines() if line.startswith("{")]
    (error,) = [line for line in lines if line.get("event") == "memory_server_config_invalid"]
    assert "MEMORY_OUTCOME_WEIGHT" in error["error"]
