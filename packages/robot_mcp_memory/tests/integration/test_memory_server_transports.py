"""The real ``robot-mcp-memory`` process, driven by a real MCP client over each transport."""

import asyncio
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
    assert_refuses_strangers,
    fresh_token,
    mcp_transport,
    wait_for_tcp_port,
)
from robot_stack_testing.kit.tool_calls import approved

TOKEN = fresh_token()  # the server's MCP_AUTH_TOKEN
APPROVALS = fresh_token()  # the server's MCP_APPROVAL_SECRET (the brain signs with it)
OPERATOR = fresh_token()  # the server's MCP_OPERATOR_TOKEN (an operator's tool)
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
            "MCP_APPROVAL_SECRET": APPROVALS,
            "MCP_OPERATOR_TOKEN": OPERATOR,
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
    meta = approved(APPROVALS, "memory", tool, arguments) if tool == "save_process" else None
    result = await client.call_tool(
        tool,
        arguments,
        read_timeout_seconds=30,
        meta=cast(RequestParamsMeta, meta) if meta is not None else None,
    )
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


async def save(
    client: Client, markdown: str, meta: dict[str, Any] | None
) -> tuple[bool, dict[str, Any]]:
    result = await client.call_tool(
        "save_process",
        {"markdown": markdown},
        read_timeout_seconds=30,
        meta=cast(RequestParamsMeta, meta) if meta is not None else None,
    )
    return bool(result.is_error), json.loads(result.content[0].text)  # type: ignore[union-attr]


@pytest.mark.parametrize("transport", ["sse", "streamable-http"])
async def test_save_process_stores_only_with_the_brains_signed_approval_once(
    launcher: ProcessLauncher, tcp_port: int, tmp_path: Path, docs: Any, transport: str
) -> None:
    """Issue 35: save_process with the operator's credential stored a process, no approval.
    Whoever calls, no approval / a forged / another call's / a stale / a replayed approval
    stores nothing; the brain's approval of that exact call stores it once."""
    process = start_server(launcher, tmp_path / "memory.sqlite3", transport, tcp_port)
    url = f"http://127.0.0.1:{tcp_port}/{'sse' if transport == 'sse' else 'mcp'}"
    doc = docs.escort
    genuine = approved(APPROVALS, "memory", "save_process", {"markdown": doc}, by="alice")
    key = next(iter(genuine))
    entry = genuine[key]
    stale = approved(APPROVALS, "memory", "save_process", {"markdown": doc})
    stale[key]["expires"] -= 600  # changed after signing: the signature no longer verifies
    refusals = {
        "none": None,
        "made-up approver": {key: {**entry, "by": "mallory"}},
        "another secret": approved(fresh_token(), "memory", "save_process", {"markdown": doc}),
        "other arguments": approved(APPROVALS, "memory", "save_process", {"markdown": docs.plants}),
        "changed expiry": stale,
    }
    answers: dict[str, tuple[bool, dict[str, Any]]] = {}
    async with Client(mcp_transport(url, OPERATOR), read_timeout_seconds=30) as operator:
        for name, meta in refusals.items():
            answers[f"operator, {name}"] = await save(operator, doc, meta)
    async with Client(mcp_transport(url, TOKEN), read_timeout_seconds=30) as brain:
        for name, meta in refusals.items():
            answers[f"brain, {name}"] = await save(brain, doc, meta)
        _, empty = await call(brain, "list_processes")
        stored = await save(brain, doc, genuine)
        replayed = await save(brain, doc.replace("slowly", "quickly"), genuine)
        again = await save(brain, doc, genuine)
        _, listed = await call(brain, "list_processes")
    for name, (error, body) in answers.items():
        assert error, name
        wanted = "approval_required" if name.endswith("none") else "approval_invalid"
        assert body["error"] == wanted, (name, body)
    assert empty["total"] == 0  # nothing was stored
    assert stored[0] is False, stored
    assert stored[1]["version"] == 1
    assert replayed[1]["error"] == "approval_invalid"  # other text, and used already
    assert again[1]["error"] == "approval_invalid"
    assert "(replayed)" in again[1]["detail"]
    assert listed["total"] == 1
    events = [json.loads(line) for line in process.log().splitlines() if line.startswith("{")]
    refused = [e for e in events if e.get("event") == "approval_refused"]
    assert len(refused) == len(answers) + 2
    assert {e["check"] for e in refused} >= {"none", "bad_signature", "other_arguments"}
    for secret in (APPROVALS, TOKEN, OPERATOR, entry["sig"]):
        assert secret not in process.log()


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
            env={
                "MCP_TRANSPORT": "stdio",
                "MCP_APPROVAL_SECRET": APPROVALS,
                "MEMORY_DB": str(db),
                "ROBOT_ID": robot_id,
            },
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
