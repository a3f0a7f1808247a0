"""The brain signs the approvals it sends (issue 35 item 4): through the guard and the real MCP
backend to a real memory server, an operator's yes stores the process once; the same call
without the server's approval secret, or sent again, stores nothing more."""

from __future__ import annotations

import json
import sys
import uuid
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from pathlib import Path
from typing import Any

import pytest
from pydantic import SecretStr

from robot_mcp_memory.documents import render_process
from robot_stack_testing import (
    LaunchedProcess,
    ProcessLauncher,
    free_tcp_port,
    fresh_token,
    wait_for_tcp_port,
)
from robot_voice_chat.control.context import DispatchContext, dispatching
from robot_voice_chat.control.guard import ApprovalAnswer, GuardedToolBackend
from robot_voice_chat.control.latch import SafetyLatch
from robot_voice_chat.control.latch_store import MemoryLatchStore
from robot_voice_chat.control.policy import ToolPolicy
from robot_voice_chat.services.tools.mcp import McpToolBackend
from robot_voice_chat.settings import CONFIG_DIR, McpServerConfig

TOKEN = fresh_token()
APPROVALS = fresh_token()
DOC = render_process(
    "water-office-plants",
    "Water the office plants",
    "water every plant on the office floor",
    ["plants", "watering"],
    ["fill the watering can in the kitchen", "visit each plant and water it"],
)


class YesGate:
    """An operator who approves every card, each with its own approval id."""

    def __init__(self) -> None:
        self.asked: list[str] = []

    async def ask(
        self, tool: str, arguments: dict[str, Any], reason: str, context: DispatchContext
    ) -> ApprovalAnswer:
        self.asked.append(tool)
        approval_id = f"ap-{uuid.uuid4().hex[:12]}"
        return ApprovalAnswer(True, "approved by alice", approval_id=approval_id, operator="alice")


@pytest.fixture
def memory_server(launcher: ProcessLauncher, tmp_path: Path) -> tuple[LaunchedProcess, str]:
    port = free_tcp_port()
    process = launcher.start(
        "memory",
        [sys.executable, "-m", "robot_mcp_memory"],
        env={
            "MCP_TRANSPORT": "sse",
            "MCP_PORT": str(port),
            "MCP_AUTH_TOKEN": TOKEN,
            "MCP_APPROVAL_SECRET": APPROVALS,
            "MEMORY_DB": str(tmp_path / "memory.sqlite3"),
        },
    )
    wait_for_tcp_port(port, 30)
    return process, f"http://127.0.0.1:{port}/sse"


@asynccontextmanager
async def guarded(
    url: str, secret: str | None
) -> AsyncIterator[tuple[GuardedToolBackend, YesGate]]:
    """The brain's tool path: the guard (shipped policy: memory.save_process is confirm) in
    front of the real MCP backend connected to ``url``."""
    config = McpServerConfig(
        name="memory",
        transport="sse",
        url=url,
        auth_token=SecretStr(TOKEN),
        approval_secret=SecretStr(secret) if secret is not None else None,
    )
    backend = McpToolBackend([config], reconnect_interval_s=0.5)
    gate = YesGate()
    policy = ToolPolicy.load(CONFIG_DIR / "policy.yaml")
    await backend.start()
    try:
        await backend.wait_connected("memory", 30)
        yield GuardedToolBackend(backend, SafetyLatch(MemoryLatchStore()), policy, gate), gate
    finally:
        await backend.aclose()


async def listed(tools: GuardedToolBackend) -> int:
    answer = await tools.call_tool("memory.list_processes", {})
    assert not answer.is_error, answer.text
    total: int = json.loads(answer.text)["total"]
    return total


def log_events(process: LaunchedProcess) -> list[dict[str, Any]]:
    return [json.loads(line) for line in process.log().splitlines() if line.startswith("{")]


async def test_an_approved_save_process_is_stored_once_with_the_operators_name(
    memory_server: tuple[LaunchedProcess, str],
) -> None:
    process, url = memory_server
    async with guarded(url, APPROVALS) as (tools, gate):
        assert await listed(tools) == 0
        saved = await tools.call_tool("memory.save_process", {"markdown": DOC})
        assert not saved.is_error, saved.text
        assert json.loads(saved.text)["version"] == 1
        assert gate.asked == ["memory.save_process"]
        assert await listed(tools) == 1
    accepted = [e for e in log_events(process) if e.get("event") == "approval_accepted"]
    assert [(e["tool"], e["by"], e["principal"]) for e in accepted] == [
        ("save_process", "alice", "brain")
    ]
    assert APPROVALS not in process.log()


async def test_a_teach_button_preapproval_is_signed_too(
    memory_server: tuple[LaunchedProcess, str],
) -> None:
    process, url = memory_server
    async with guarded(url, APPROVALS) as (tools, gate):
        with dispatching(DispatchContext(approved_by="teaching armed by alice")):
            saved = await tools.call_tool("memory.save_process", {"markdown": DOC})
        assert not saved.is_error, saved.text
        assert gate.asked == []  # the Teach button was the operator's yes
        assert await listed(tools) == 1
    accepted = [e for e in log_events(process) if e.get("event") == "approval_accepted"]
    assert [e["by"] for e in accepted] == ["teaching armed by alice"]


async def test_without_the_servers_approval_secret_the_brain_stores_nothing(
    memory_server: tuple[LaunchedProcess, str],
) -> None:
    _, url = memory_server
    async with guarded(url, None) as (tools, gate):
        refused = await tools.call_tool("memory.save_process", {"markdown": DOC})
        assert refused.is_error
        assert json.loads(refused.text)["error"] == "approval_required"
        assert gate.asked == ["memory.save_process"]
        assert await listed(tools) == 0
    async with guarded(url, fresh_token()) as (tools, _):  # a wrong secret: a forged one
        refused = await tools.call_tool("memory.save_process", {"markdown": DOC})
        assert json.loads(refused.text)["error"] == "approval_invalid"
        assert "(bad_signature)" in json.loads(refused.text)["detail"]
        assert await listed(tools) == 0
