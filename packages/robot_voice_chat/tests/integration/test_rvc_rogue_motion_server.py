"""The brain against a real motion server that claims read-only tools (issue 27 items 3, 4):
over streamable-http with the server's credential, the latched stop and the policy hold
whatever the annotations say, and a wrong credential never connects."""

from __future__ import annotations

import json
import sys
from collections.abc import AsyncIterator, Iterator
from pathlib import Path

import pytest
import structlog

from robot_stack_testing import (
    LaunchedProcess,
    ProcessLauncher,
    async_wait_until,
    free_tcp_port,
    fresh_token,
    wait_for_tcp_port,
)
from robot_voice_chat.control.guard import GuardedToolBackend
from robot_voice_chat.control.latch import SAFETY_STOP_LATCHED, SafetyLatch
from robot_voice_chat.control.latch_store import MemoryLatchStore
from robot_voice_chat.control.policy import POLICY_DENIED, ToolPolicy
from robot_voice_chat.services.tools.mcp import McpToolBackend
from robot_voice_chat.settings import CONFIG_DIR, McpServerConfig

ROGUE = Path(__file__).parent / "rvc_rogue_motion_server.py"
TOKEN = fresh_token()


@pytest.fixture(scope="module")
def rogue_server(
    tmp_path_factory: pytest.TempPathFactory,
) -> Iterator[tuple[LaunchedProcess, str, Path]]:
    """One rogue server for the module; each test reads only what it added to ``calls``."""
    tmp_path = tmp_path_factory.mktemp("rogue")
    launcher = ProcessLauncher(tmp_path)
    port, calls = free_tcp_port(), tmp_path / "calls.jsonl"
    calls.touch()
    process = launcher.start(
        "rogue",
        [sys.executable, str(ROGUE)],
        env={
            "MCP_TRANSPORT": "streamable-http",
            "MCP_PORT": str(port),
            "MCP_AUTH_TOKEN": TOKEN,
            "ROGUE_CALLS": str(calls),
        },
    )
    try:
        wait_for_tcp_port(port, 30)
        yield process, f"http://127.0.0.1:{port}/mcp", calls
    finally:
        launcher.stop_all()


def config(url: str, token: str) -> McpServerConfig:
    return McpServerConfig(
        name="rogue",
        transport="streamable_http",
        url=url,
        auth_token=token,  # type: ignore[arg-type]
        motion=True,
        safety_stop_tool="halt",
    )


@pytest.fixture
async def connected(
    rogue_server: tuple[LaunchedProcess, str, Path],
) -> AsyncIterator[McpToolBackend]:
    _, url, _ = rogue_server
    tools = McpToolBackend([config(url, TOKEN)], connect_timeout_s=30, reconnect_interval_s=0.3)
    await tools.start()
    try:
        await tools.wait_connected("rogue", 30)
        yield tools
    finally:
        await tools.aclose()


async def test_a_rogue_motion_server_gets_nothing_while_latched_and_is_confirmed_after(
    connected: McpToolBackend, rogue_server: tuple[LaunchedProcess, str, Path]
) -> None:
    _, _, calls = rogue_server
    before = len(calls.read_text().splitlines())
    annotations = {t.name: t.annotations for t in connected.list_tools()}
    assert annotations["rogue.drive_velocity"]["readOnlyHint"] is True  # what it claims
    policy = ToolPolicy.load(CONFIG_DIR / "policy.yaml")
    guard = GuardedToolBackend(connected, SafetyLatch(MemoryLatchStore()), policy)
    await guard.latch.stop("alice", "Stop robot (operator UI)")

    drive = await guard.call_tool("rogue.drive_velocity", {"speed_mps": 1.5})
    go = await guard.call_tool("rogue.navigate_to", {"location": "kitchen"})
    halted = await guard.call_tool("rogue.halt", {})

    assert json.loads(drive.text)["error"] == SAFETY_STOP_LATCHED
    assert json.loads(go.text)["error"] == SAFETY_STOP_LATCHED
    assert not halted.is_error, halted.text  # the stop tool still reaches it
    await guard.latch.clear("alice", "corridor checked")
    unasked = await guard.call_tool("rogue.drive_velocity", {"speed_mps": 1.5})
    assert json.loads(unasked.text)["error"] == POLICY_DENIED  # confirm, and nobody to ask
    received = calls.read_text().splitlines()[before:]
    assert [json.loads(line)["tool"] for line in received] == ["halt"]


async def test_a_wrong_credential_never_connects_and_says_which_setting_to_fix(
    rogue_server: tuple[LaunchedProcess, str, Path],
) -> None:
    process, url, calls = rogue_server
    before = calls.read_text()
    tools = McpToolBackend(
        [config(url, fresh_token())], connect_timeout_s=10, reconnect_interval_s=30
    )
    with structlog.testing.capture_logs() as logs:
        await tools.start()
        try:
            await async_wait_until(
                lambda: any(e["event"] == "mcp_server_unauthorized" for e in logs),
                30,
                "the refusal logged",
            )
            assert tools.server_states()["rogue"] != "connected"
            assert tools.list_tools() == []
            refused = await tools.call_tool("rogue.drive_velocity", {"speed_mps": 1.5})
        finally:
            await tools.aclose()
    assert refused.is_error
    unauthorized = next(e for e in logs if e["event"] == "mcp_server_unauthorized")
    assert "MCP_AUTH_TOKEN" in unauthorized["detail"]
    assert TOKEN not in str(logs)
    assert calls.read_text() == before  # nothing reached the server
    assert '"event": "mcp_auth_rejected"' in process.log()
