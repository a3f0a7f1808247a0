"""Sessions belong to their principal (issue 35 item 5), over real HTTP in a real server
process: a session the brain opened refuses messages, GETs and DELETE sent with the operator's
credential (404, as for a session that does not exist), keeps working for the brain, and its id
is written to no log line."""

from __future__ import annotations

import asyncio
import contextlib
import json
import sys
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from pathlib import Path

import httpx
import pytest

from robot_stack_testing import (
    LaunchedProcess,
    ProcessLauncher,
    bearer,
    free_tcp_port,
    fresh_token,
    wait_for_tcp_port,
    wait_until,
)

PROC = Path(__file__).parent / "procs" / "kit_mcp_server.py"
BRAIN = fresh_token()
OPERATOR = fresh_token()
ACCEPT = {"accept": "application/json, text/event-stream"}
INITIALIZE = {
    "jsonrpc": "2.0",
    "id": 1,
    "method": "initialize",
    "params": {
        "protocolVersion": "2025-06-18",
        "capabilities": {},
        "clientInfo": {"name": "session-test", "version": "1"},
    },
}
INITIALIZED = {"jsonrpc": "2.0", "method": "notifications/initialized"}
LIST_TOOLS = {"jsonrpc": "2.0", "id": 2, "method": "tools/list"}


@pytest.fixture
def server(
    launcher: ProcessLauncher, request: pytest.FixtureRequest
) -> tuple[LaunchedProcess, int]:
    port = free_tcp_port()
    proc = launcher.start(
        f"mcp-{request.param}",
        [sys.executable, str(PROC)],
        env={
            "MCP_TRANSPORT": request.param,
            "MCP_PORT": str(port),
            "LOG_LEVEL": "INFO",
            "MCP_AUTH_TOKEN": BRAIN,
            "MCP_OPERATOR_TOKEN": OPERATOR,
        },
    )
    wait_for_tcp_port(port, 20)
    return proc, port


@asynccontextmanager
async def sse_session(
    http: httpx.AsyncClient, port: int
) -> AsyncIterator[tuple[str, asyncio.Queue[str]]]:
    """The brain's SSE stream: (the message path with its session id, the stream's data)."""
    data: asyncio.Queue[str] = asyncio.Queue()
    endpoint: asyncio.Future[str] = asyncio.get_running_loop().create_future()

    async def read() -> None:
        url = f"http://127.0.0.1:{port}/sse"
        async with http.stream("GET", url, headers=bearer(BRAIN)) as stream:
            event = ""
            async for line in stream.aiter_lines():
                if line.startswith("event:"):
                    event = line.partition(":")[2].strip()
                elif line.startswith("data:"):
                    value = line.partition(":")[2].strip()
                    if event == "endpoint" and not endpoint.done():
                        endpoint.set_result(value)
                    else:
                        await data.put(value)

    reader = asyncio.create_task(read())
    try:
        yield await asyncio.wait_for(endpoint, 10), data
    finally:
        reader.cancel()
        with contextlib.suppress(asyncio.CancelledError, httpx.HTTPError):
            await reader


@pytest.mark.parametrize("server", ["sse"], indirect=True)
async def test_an_sse_session_takes_messages_only_with_the_credential_that_opened_it(
    server: tuple[LaunchedProcess, int],
) -> None:
    proc, port = server
    base = f"http://127.0.0.1:{port}"
    async with (
        httpx.AsyncClient(timeout=10.0) as http,
        sse_session(http, port) as (path, data),
    ):
        session_id = path.partition("session_id=")[2]
        assert len(session_id) == 32
        intruder = await http.post(base + path, headers=bearer(OPERATOR), json=INITIALIZE)
        assert intruder.status_code == 404, intruder.text
        assert "session" in intruder.text.lower()
        assert data.empty()  # nothing reached the brain's session
        own = await http.post(base + path, headers=bearer(BRAIN), json=INITIALIZE)
        assert own.status_code == 202, own.text
        answer = json.loads(await asyncio.wait_for(data.get(), 10))
        assert answer["id"] == 1
        assert "result" in answer
    wait_until(lambda: "POST /messages/" in proc.log(), 10, "the access log lines")
    log = proc.log()
    assert session_id not in log
    assert "session_id=<redacted>" in log
    assert "Traceback" not in log
    for secret in (BRAIN, OPERATOR):
        assert secret not in log


@pytest.mark.parametrize("server", ["streamable-http"], indirect=True)
async def test_a_streamable_http_session_refuses_another_credential_and_its_delete(
    server: tuple[LaunchedProcess, int],
) -> None:
    proc, port = server
    url = f"http://127.0.0.1:{port}/mcp"
    async with httpx.AsyncClient(timeout=10.0) as http:
        opened = await http.post(url, headers={**bearer(BRAIN), **ACCEPT}, json=INITIALIZE)
        assert opened.status_code == 200, opened.text
        session_id = opened.headers["mcp-session-id"]
        mine = {**bearer(BRAIN), **ACCEPT, "mcp-session-id": session_id}
        theirs = {**bearer(OPERATOR), **ACCEPT, "mcp-session-id": session_id}
        assert (await http.post(url, headers=mine, json=INITIALIZED)).status_code == 202

        posted = await http.post(url, headers=theirs, json=LIST_TOOLS)
        deleted = await http.delete(url, headers=theirs)
        for refused in (posted, deleted):
            assert refused.status_code == 404, refused.text
            assert "session not found" in refused.text.lower()

        listed = await http.post(url, headers=mine, json=LIST_TOOLS)  # still the brain's
        assert listed.status_code == 200, listed.text
        assert "whoami" in listed.text
        assert (await http.delete(url, headers=mine)).status_code == 200
        gone = await http.post(url, headers=mine, json=LIST_TOOLS)
        assert gone.status_code == 404
    log = proc.log()
    assert session_id not in log
    assert "Traceback" not in log
    for secret in (BRAIN, OPERATOR):
        assert secret not in log
