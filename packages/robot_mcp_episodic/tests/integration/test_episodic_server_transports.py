"""The real ``robot-mcp-episodic`` process over each transport, on SQLite and PostgreSQL, its
refusals to start (exit 2, one line), and ``forget`` over HTTP only for the brain's credential
with an operator's approval signed with the server's approval secret (issue 27 item 3, issue 35
item 4)."""

from __future__ import annotations

import asyncio
import os
import sys
from pathlib import Path
from typing import Any

import pytest
from mcp import Client
from mcp.client.stdio import StdioServerParameters

from robot_mcp_kit.approvals import signed_approval
from robot_stack_testing import (
    LaunchedProcess,
    ProcessLauncher,
    assert_refuses_strangers,
    free_tcp_port,
    fresh_token,
    mcp_transport,
    wait_for_tcp_port,
)
from robot_stack_testing.kit.tool_calls import tool_answer
from robot_stack_testing.processes import start_refusal

pytestmark = [pytest.mark.ros]

SERVER = str(Path(sys.executable).parent / "robot-mcp-episodic")
BRAIN = fresh_token()
OPERATOR = fresh_token()
APPROVALS = fresh_token()


def approval(arguments: dict[str, Any], by: str, approval_id: str) -> dict[str, Any]:
    return signed_approval(
        APPROVALS,
        server="episodic",
        tool="forget",
        arguments=arguments,
        approval_id=approval_id,
        by=by,
    )


def start(launcher: ProcessLauncher, env: dict[str, str]) -> tuple[LaunchedProcess, int]:
    port = free_tcp_port()
    env = {"MCP_PORT": str(port), "MCP_AUTH_TOKEN": BRAIN, **env}
    process = launcher.start("episodic", [SERVER], env=env)
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


async def test_notes_survive_a_restart_on_postgres_and_only_the_approved_brain_forgets(
    launcher: ProcessLauncher, tmp_path: Path, postgres_dsn: str
) -> None:
    """Written over sse, read back after a restart over streamable-http; there (issue 27)
    ``forget`` deletes only for the brain's credential with an operator's approval of that
    exact call: the operator's credential, or no approval, deletes nothing; no credential, 401."""
    env = {
        "MCP_TRANSPORT": "sse", "EPISODIC_DIR": str(tmp_path), "EPISODIC_STORE": "postgres",
        "EPISODIC_POSTGRES_DSN": postgres_dsn, "ROBOT_ID": "robot-7",
        "MCP_OPERATOR_TOKEN": OPERATOR, "MCP_APPROVAL_SECRET": APPROVALS,
    }  # fmt: skip
    process, port = start(launcher, env)
    async with Client(mcp_transport(f"http://127.0.0.1:{port}/sse", BRAIN)) as client:
        found = await note_then_find(client, "The kettle in the kitchen is broken")
    assert [r["text"] for r in found["results"]] == ["The kettle in the kitchen is broken"]
    assert launcher.stop(process) == 0

    process, port = start(launcher, {**env, "MCP_TRANSPORT": "streamable-http"})
    url = f"http://127.0.0.1:{port}/mcp"
    await asyncio.to_thread(assert_refuses_strangers, url, "episodic")
    everything = {"start": "-36500d", "end": "now", "dry_run": False}
    async with Client(mcp_transport(url, BRAIN)) as brain:
        found = await tool_answer(brain, "search_memory", {"query": "kettle"})
        status = await tool_answer(brain, "memory_status", {})
        unapproved = await tool_answer(brain, "forget", everything)
        genuine = approval(everything, "alice", "ap-123456789abc")
        mallory = {k: {**v, "by": "mallory"} for k, v in genuine.items()}  # issue 35's forgery
        forged = await tool_answer(brain, "forget", everything, mallory)
    async with Client(mcp_transport(url, OPERATOR)) as operator:  # the Inspector, say
        not_brain = await tool_answer(operator, "forget", everything, genuine)
        kept = await tool_answer(operator, "search_memory", {"query": "kettle"})
    assert found["found"] is True
    assert status["robot_id"] == "robot-7"
    assert unapproved["_error"]["error"] == "approval_required"
    assert forged["_error"]["error"] == "approval_invalid"
    assert "(bad_signature)" in forged["_error"]["detail"]
    assert not_brain["_error"]["error"] == "not_permitted"
    assert kept["found"] is True  # nothing was deleted

    async with Client(mcp_transport(url, BRAIN)) as brain:
        done = await tool_answer(brain, "forget", everything, genuine)
        replayed = await tool_answer(brain, "forget", everything, genuine)
        status = await tool_answer(brain, "memory_status", {})
    assert done["deleted"]["notes"] == 1
    assert replayed["_error"]["error"] == "approval_invalid"
    assert len(status["forget_audit"]) == 1
    assert status["forget_audit"][0]["request"]["approved_by"] == "alice"
    assert BRAIN not in process.log()
    assert OPERATOR not in process.log()
    assert APPROVALS not in process.log()
    assert genuine["robot-stack/approval"]["sig"] not in process.log()
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
    line = start_refusal(
        "robot_mcp_episodic", tmp_path, {"MCP_TRANSPORT": "sse", "MCP_AUTH_TOKEN": BRAIN, **env}
    )
    assert line.startswith("robot-mcp-episodic: cannot start:")
    assert says in line
