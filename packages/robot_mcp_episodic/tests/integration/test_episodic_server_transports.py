"""The real ``robot-mcp-episodic`` process over each transport, on SQLite and PostgreSQL, and
its refusals to start (exit 2, one line)."""

from __future__ import annotations

import os
import sys
from pathlib import Path
from typing import Any

import pytest
from mcp import Client
from mcp.client.sse import sse_client
from mcp.client.stdio import StdioServerParameters

from robot_mcp_kit.testing_mcp import tool_answer
from robot_stack_testing import LaunchedProcess, ProcessLauncher, free_tcp_port, wait_for_tcp_port
from robot_stack_testing.processes import start_refusal

pytestmark = [pytest.mark.ros]

SERVER = str(Path(sys.executable).parent / "robot-mcp-episodic")


def start(launcher: ProcessLauncher, env: dict[str, str]) -> tuple[LaunchedProcess, int]:
    port = free_tcp_port()
    process = launcher.start("episodic", [SERVER], env={"MCP_PORT": str(port), **env})
    try:
        wait_for_tcp_port(port, 45.0)
    except TimeoutError:
        pytest.fail(f"episodic server did not listen on {port}:\n{process.log()}")
    return process, port


async def note_then_find(client: Client, text: str) -> dict[str, Any]:
    noted = await tool_answer(client, "record_note", {"kind": "user", "text": text})
    assert "_error" not in noted, noted
    found: dict[str, Any] = await tool_answer(client, "search_memory", {"query": "kettle"})
    return found


async def test_notes_survive_a_restart_over_sse_on_postgres(
    launcher: ProcessLauncher, tmp_path: Path, postgres_dsn: str
) -> None:
    env = {
        "MCP_TRANSPORT": "sse", "EPISODIC_DIR": str(tmp_path), "EPISODIC_STORE": "postgres",
        "EPISODIC_POSTGRES_DSN": postgres_dsn, "ROBOT_ID": "robot-7",
    }  # fmt: skip
    process, port = start(launcher, env)
    async with Client(sse_client(f"http://127.0.0.1:{port}/sse")) as client:
        found = await note_then_find(client, "The kettle in the kitchen is broken")
    assert [r["text"] for r in found["results"]] == ["The kettle in the kitchen is broken"]
    assert launcher.stop(process) == 0

    process, port = start(launcher, env)
    async with Client(sse_client(f"http://127.0.0.1:{port}/sse")) as client:
        found = await tool_answer(client, "search_memory", {"query": "kettle"})
        status = await tool_answer(client, "memory_status", {})
    assert found["found"] is True
    assert status["robot_id"] == "robot-7"
    assert launcher.stop(process) == 0


async def test_the_stdio_transport_serves_the_tools(tmp_path: Path) -> None:
    params = StdioServerParameters(
        command=SERVER,
        env={**os.environ, "MCP_TRANSPORT": "stdio", "EPISODIC_DIR": str(tmp_path)},
    )
    async with Client(params, read_timeout_seconds=60) as client:
        found = await note_then_find(client, "Bob asked for a new kettle")
    assert found["results"][0]["text"] == "Bob asked for a new kettle"
    async with Client(params, read_timeout_seconds=60) as client:
        again = await tool_answer(client, "search_memory", {"query": "kettle"})
    assert again["found"] is True
    assert (tmp_path / "episodic.sqlite3").exists()


@pytest.mark.parametrize(
    ("env", "says"),
    [
        ({"EPISODIC_STORE": "postgres"}, "EPISODIC_POSTGRES_DSN"),
        ({"EPISODIC_DIR": "relative/dir"}, "absolute path"),
        ({"EPISODIC_FLUSH_S": "-1"}, "flush_s"),
        ({"EPISODIC_MAP_FILE": "/nonexistent/map.yaml"}, "no map file"),
        ({"EPISODIC_TIMEZONE": "Mars/Olympus"}, "unknown time zone 'Mars/Olympus'"),
        ({"EPISODIC_TIMEZONE": "../../etc/passwd"}, "EPISODIC_TIMEZONE"),
        ({"MCP_TRANSPORT": "carrier-pigeon"}, "MCP_TRANSPORT"),
        (
            {"EPISODIC_STORE": "postgres",
             "EPISODIC_POSTGRES_DSN": "postgresql://nobody@127.0.0.1:1/none?connect_timeout=1"},
            "cannot open the episodic index",
        ),
    ],
)  # fmt: skip
def test_a_bad_setting_refuses_to_start_with_one_line(
    tmp_path: Path, env: dict[str, str], says: str
) -> None:
    line = start_refusal("robot_mcp_episodic", tmp_path, {"MCP_TRANSPORT": "sse", **env})
    assert line.startswith("robot-mcp-episodic: cannot start:")
    assert says in line
