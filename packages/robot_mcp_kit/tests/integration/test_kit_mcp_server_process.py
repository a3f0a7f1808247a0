"""run_server + tool_error in a real server process, over sse and streamable-http."""

from __future__ import annotations

import asyncio
import contextlib
import json
import signal
import sys
from pathlib import Path
from typing import Any

import pytest
from mcp import Client
from mcp.client.sse import sse_client

from robot_stack_testing import ProcessLauncher, wait_for_tcp_port

PROC = Path(__file__).parent / "procs" / "kit_mcp_server.py"


@pytest.mark.parametrize("transport", ["streamable-http", "sse"])
async def test_a_tool_error_crosses_a_real_transport_as_json(
    launcher: ProcessLauncher, tcp_port: int, transport: str
) -> None:
    proc = launcher.start(
        f"mcp-{transport}",
        [sys.executable, str(PROC)],
        env={"MCP_TRANSPORT": transport, "MCP_PORT": str(tcp_port), "LOG_LEVEL": "INFO"},
    )
    await asyncio.to_thread(wait_for_tcp_port, tcp_port, 20)
    base = f"http://127.0.0.1:{tcp_port}"
    target: Any = sse_client(f"{base}/sse") if transport == "sse" else f"{base}/mcp"
    async with Client(target) as client:
        failed = await client.call_tool("fail", {"code": "NO_PATH", "detail": "blocked"})
        ok = await client.call_tool("echo", {"text": "hi"})

    assert failed.is_error is True
    assert json.loads(failed.content[0].text) == {  # type: ignore[union-attr]
        "error": "NO_PATH",
        "detail": "blocked",
    }
    assert ok.is_error is False
    assert proc.running(), proc.log()
    log_lines = [line for line in proc.log().splitlines() if line.startswith("{")]
    assert any(json.loads(line).get("service") == "kit-proc" for line in log_lines), proc.log()


@pytest.mark.parametrize("transport", ["sse", "streamable-http"])
@pytest.mark.parametrize("stop", [signal.SIGINT, signal.SIGTERM])
async def test_a_normal_stop_with_a_client_connected_is_quiet_and_cleans_up(
    launcher: ProcessLauncher, tcp_port: int, transport: str, stop: signal.Signals
) -> None:
    """Issue 31: "Exception in ASGI application" (the SSE route's second response start) and
    interrupt tracebacks on every normal stop; a SIGTERM skipped the server's own cleanup."""
    proc = launcher.start(
        f"mcp-{transport}",
        [sys.executable, str(PROC)],
        env={"MCP_TRANSPORT": transport, "MCP_PORT": str(tcp_port), "LOG_LEVEL": "INFO"},
    )
    await asyncio.to_thread(wait_for_tcp_port, tcp_port, 20)
    base = f"http://127.0.0.1:{tcp_port}"
    target: Any = sse_client(f"{base}/sse") if transport == "sse" else f"{base}/mcp"
    with contextlib.suppress(Exception):  # the server goes away under the client
        async with Client(target) as client:
            assert (await client.call_tool("echo", {"text": "hi"})).is_error is False
            proc.popen.send_signal(stop)  # a stop while the client's stream is open
            await asyncio.to_thread(proc.popen.wait, 30)
    code = await asyncio.to_thread(proc.popen.wait, 30)
    log = proc.log()
    assert code == 0, log
    assert "Traceback" not in log, log
    assert "Exception in ASGI application" not in log
    assert "ERROR:" not in log  # nor "ASGI callable returned without completing response"
    events = [json.loads(line)["event"] for line in log.splitlines() if line.startswith("{")]
    assert "mcp_server_stopped" in events, log
    assert "cleaned up" in log  # the code after run_server ran
