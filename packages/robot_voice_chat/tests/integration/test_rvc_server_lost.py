"""A server that dies is noticed by the MCP backend and reported to its disconnect listeners
(issue 23 item 4): kill -9 of a real MCP server process; the brain's listener runs within
``health_interval_s + connect_timeout_s`` (the bound the mission is told within)."""

from __future__ import annotations

import os
import signal
import sys
from pathlib import Path

from robot_stack_testing import ProcessLauncher, async_wait_until, free_tcp_port
from robot_voice_chat.services.tools.mcp import McpToolBackend
from robot_voice_chat.settings import McpServerConfig

SERVERS = Path(__file__).with_name("rvc_fake_mcp_servers.py")
HEALTH_S, CONNECT_S = 0.5, 2.0


async def test_a_killed_server_reaches_the_disconnect_listeners_within_the_bound(
    launcher: ProcessLauncher, tmp_path: Path
) -> None:
    port = free_tcp_port()
    process = launcher.start("memory", [sys.executable, str(SERVERS), "memory", str(port)])
    backend = McpToolBackend(
        [
            McpServerConfig(
                name="memory", transport="streamable_http", url=f"http://127.0.0.1:{port}/mcp"
            )
        ],
        connect_timeout_s=CONNECT_S,
        reconnect_interval_s=0.3,
        health_interval_s=HEALTH_S,
    )
    connected: list[str] = []
    lost: list[str] = []

    async def on_connect(server: str) -> None:
        connected.append(server)

    async def on_lost(server: str) -> None:
        lost.append(server)

    backend.add_connect_listener(on_connect)
    backend.add_disconnect_listener(on_lost)
    await backend.start()
    try:
        await async_wait_until(lambda: connected, 60, "memory connected")
        assert lost == []
        os.kill(process.pid, signal.SIGKILL)
        process.popen.wait(timeout=10)
        await async_wait_until(lambda: lost, HEALTH_S + CONNECT_S + 10, "the loss reported")
        assert lost == ["memory"]
        assert backend.server_states()["memory"] != "connected"
    finally:
        await backend.aclose()
    assert len(lost) == 1  # closing the backend is not a loss
