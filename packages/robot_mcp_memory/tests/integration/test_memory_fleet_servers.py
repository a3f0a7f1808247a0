"""Real ``robot-mcp-memory`` processes of two robots on one throwaway PostgreSQL database."""

import json
import sys
from pathlib import Path
from typing import Any, cast

import pytest
from mcp import Client
from mcp.client.stdio import StdioServerParameters
from mcp.types import RequestParamsMeta

from robot_stack_testing import (
    LaunchedProcess,
    ProcessLauncher,
    free_tcp_port,
    fresh_token,
    mcp_transport,
    wait_for_tcp_port,
)
from robot_stack_testing.kit.tool_calls import approved

TOKEN = fresh_token()  # the server's MCP_AUTH_TOKEN
APPROVALS = fresh_token()  # the server's MCP_APPROVAL_SECRET (the brain signs with it)
SERVER = str(Path(sys.executable).parent / "robot-mcp-memory")
QUERY = "fetch the package from the mailroom"
MAILROOM = "fetch-package-from-mailroom"
WEST = "fetch-package-from-mailroom-west"


def start_robot(launcher: ProcessLauncher, dsn: str, robot_id: str) -> tuple[LaunchedProcess, str]:
    port = free_tcp_port()
    process = launcher.start(
        f"memory-{robot_id}",
        [SERVER],
        env={
            "MCP_TRANSPORT": "streamable-http",
            "MCP_AUTH_TOKEN": TOKEN,
            "MCP_APPROVAL_SECRET": APPROVALS,
            "MCP_PORT": str(port),
            "MEMORY_STORE": "postgres",
            "MEMORY_POSTGRES_DSN": dsn,
            "ROBOT_ID": robot_id,
        },
    )
    try:
        wait_for_tcp_port(port, timeout_s=30)
    except TimeoutError:
        pytest.fail(f"memory server {robot_id} did not listen on {port}:\n{process.log()}")
    return process, f"http://127.0.0.1:{port}/mcp"


async def call(client: Client, tool: str, **arguments: Any) -> dict[str, Any]:
    meta = approved(APPROVALS, "memory", tool, arguments) if tool == "save_process" else None
    result = await client.call_tool(
        tool,
        arguments,
        read_timeout_seconds=30,
        meta=cast(RequestParamsMeta, meta) if meta is not None else None,
    )
    (block,) = result.content
    assert block.type == "text"
    answer: dict[str, Any] = json.loads(block.text)
    assert not result.is_error, answer
    return answer


async def ranked(client: Client, query: str = QUERY) -> list[str]:
    found = await call(client, "find_processes", query=query, k=3)
    return [result["id"] for result in found["results"]]


async def test_robot_b_finds_what_robot_a_saved_and_its_outcomes_rerank_b(
    launcher: ProcessLauncher, postgres_dsn: str, docs: Any
) -> None:
    west = docs.mailroom.replace("id: fetch-package-from-mailroom", f"id: {WEST}")
    robot_a, url_a = start_robot(launcher, postgres_dsn, "robot-a")
    robot_b, url_b = start_robot(launcher, postgres_dsn, "robot-b")
    async with Client(mcp_transport(url_a, TOKEN), read_timeout_seconds=30) as client_a:
        for markdown in [*docs.all(), west]:
            await call(client_a, "save_process", markdown=markdown)
    async with Client(mcp_transport(url_b, TOKEN), read_timeout_seconds=30) as client_b:
        before = await ranked(client_b)
        await call(client_b, "record_outcome", process_id=WEST, success=True, note="ok")
        after = await ranked(client_b)
        seen_by_b = await call(client_b, "get_process", id=WEST)
    async with Client(mcp_transport(url_a, TOKEN), read_timeout_seconds=30) as client_a:
        await call(client_a, "record_outcome", process_id=MAILROOM, success=True, note="ok")
        on_a = await ranked(client_a)
    async with Client(mcp_transport(url_b, TOKEN), read_timeout_seconds=30) as client_b:
        still_on_b = await ranked(client_b)

    assert before[:2] == [MAILROOM, WEST]  # equal text: id order
    assert after[:2] == [WEST, MAILROOM]
    assert seen_by_b["saved_by"] == "robot-a"
    assert (seen_by_b["robot_successes"], seen_by_b["successes"]) == (1, 1)
    assert on_a[:2] == [MAILROOM, WEST]  # each robot prefers its own success
    assert still_on_b[:2] == [WEST, MAILROOM]

    launcher.stop(robot_a)
    launcher.stop(robot_b)
    _, url_a = start_robot(launcher, postgres_dsn, "robot-a")
    async with Client(mcp_transport(url_a, TOKEN), read_timeout_seconds=30) as client_a:
        listed = await call(client_a, "list_processes")
        reloaded = await call(client_a, "get_process", id=WEST)

    assert listed["total"] == 6
    assert listed["visibility"] == "fleet"
    assert (reloaded["successes"], reloaded["robot_successes"]) == (1, 0)
    assert [outcome["robot_id"] for outcome in reloaded["recent_outcomes"]] == ["robot-b"]


def only_line(process: LaunchedProcess) -> dict[str, Any]:
    """The single line the server printed (it must print exactly one)."""
    (line,) = [line for line in process.log().splitlines() if line.strip()]
    parsed: dict[str, Any] = json.loads(line)
    return parsed


@pytest.mark.parametrize(
    ("dsn", "expected"),
    [
        ("postgresql://postgres:s3cret@127.0.0.1:{port}/memory", "cannot open the PostgreSQL"),
        ("host=127.0.0.1 password=s3cret port=={port} ===", "not a valid libpq connection"),
    ],
    ids=["unreachable", "malformed"],
)
def test_an_unusable_database_stops_the_server_with_exit_2_and_one_line(
    launcher: ProcessLauncher, dsn: str, expected: str
) -> None:
    process = launcher.start(
        "memory-bad-dsn",
        [SERVER],
        env={
            "MEMORY_STORE": "postgres",
            "MEMORY_POSTGRES_DSN": dsn.format(port=free_tcp_port()),
            "MEMORY_CONNECT_TIMEOUT_S": "3",
        },
    )

    assert process.popen.wait(timeout=30) == 2
    line = only_line(process)
    assert line["event"] == "memory_store_unavailable"
    assert expected in line["error"]
    assert "s3cret" not in process.log()


def test_postgres_without_a_dsn_is_a_config_error(launcher: ProcessLauncher) -> None:
    process = launcher.start("memory-no-dsn", [SERVER], env={"MEMORY_STORE": "postgres"})

    assert process.popen.wait(timeout=30) == 2
    line = only_line(process)
    assert line["event"] == "memory_server_config_invalid"
    assert "MEMORY_POSTGRES_DSN" in line["error"]


async def test_a_server_spawned_from_the_root_directory_keeps_its_db_in_the_data_dir(
    tmp_path: Path, docs: Any
) -> None:
    data_home = tmp_path / "xdg-data"
    params = StdioServerParameters(
        command=SERVER,
        env={
            "MCP_TRANSPORT": "stdio",
            "MCP_APPROVAL_SECRET": APPROVALS,
            "XDG_DATA_HOME": str(data_home),
            "ROBOT_ID": "r1",
        },
        cwd="/",
    )

    async with Client(params, read_timeout_seconds=30) as client:
        saved = await call(client, "save_process", markdown=docs.escort)
    async with Client(params, read_timeout_seconds=30) as client:
        found = await ranked(client, "accompany a guest to the conference room")

    assert saved["version"] == 1
    assert (data_home / "robot-mcp-memory" / "memory.sqlite3").is_file()
    assert found == ["escort-visitor-to-meeting-room"]
