"""run_server in a real server process, over sse and streamable-http: tool errors as JSON, and
the credential check on every request (issue 27 item 3)."""

from __future__ import annotations

import asyncio
import contextlib
import json
import signal
import sys
from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest
from mcp import Client

from robot_stack_testing import (
    LaunchedProcess,
    ProcessLauncher,
    bearer,
    free_tcp_port,
    fresh_token,
    mcp_transport,
    run_inspector,
    wait_for_tcp_port,
    wait_until,
)

PROC = Path(__file__).parent / "procs" / "kit_mcp_server.py"
PATHS = {"sse": "/sse", "streamable-http": "/mcp"}
BRAIN_TOKEN = fresh_token()
OPERATOR_TOKEN = fresh_token()


@pytest.fixture(scope="module")
def module_launcher(tmp_path_factory: pytest.TempPathFactory) -> Iterator[ProcessLauncher]:
    processes = ProcessLauncher(tmp_path_factory.mktemp("kit-servers"))
    try:
        yield processes
    finally:
        processes.stop_all()


@pytest.fixture(scope="module", params=["streamable-http", "sse"])
def served(
    request: pytest.FixtureRequest, module_launcher: ProcessLauncher
) -> tuple[LaunchedProcess, str]:
    """One server per transport for the whole module (each test reads only its own log)."""
    transport, port = request.param, free_tcp_port()
    proc = module_launcher.start(
        f"mcp-{transport}",
        [sys.executable, str(PROC)],
        env={
            "MCP_TRANSPORT": transport,
            "MCP_PORT": str(port),
            "LOG_LEVEL": "INFO",
            "MCP_AUTH_TOKEN": BRAIN_TOKEN,
            "MCP_OPERATOR_TOKEN": OPERATOR_TOKEN,
        },
    )
    wait_for_tcp_port(port, 20)
    return proc, f"http://127.0.0.1:{port}{PATHS[transport]}"


def leaf_messages(error: BaseException) -> list[str]:
    if isinstance(error, BaseExceptionGroup):
        return [m for inner in error.exceptions for m in leaf_messages(inner)]
    return [str(error)]


def log_events(proc: LaunchedProcess, after: int = 0) -> list[dict[str, object]]:
    lines = proc.log().splitlines()[after:]
    return [json.loads(line) for line in lines if line.startswith("{")]


async def test_a_tool_error_crosses_a_real_transport_as_json(
    served: tuple[LaunchedProcess, str],
) -> None:
    proc, url = served
    async with Client(mcp_transport(url, BRAIN_TOKEN)) as client:
        failed = await client.call_tool("fail", {"code": "NO_PATH", "detail": "blocked"})
        ok = await client.call_tool("echo", {"text": "hi"})

    assert failed.is_error is True
    assert json.loads(failed.content[0].text) == {  # type: ignore[union-attr]
        "error": "NO_PATH",
        "detail": "blocked",
    }
    assert ok.is_error is False
    assert proc.running(), proc.log()
    assert any(e.get("service") == "kit-proc" for e in log_events(proc)), proc.log()


async def test_each_credential_names_its_principal_to_the_tool(
    served: tuple[LaunchedProcess, str],
) -> None:
    _, url = served
    for token, principal in ((BRAIN_TOKEN, "brain"), (OPERATOR_TOKEN, "operator")):
        async with Client(mcp_transport(url, token)) as client:
            answer = await client.call_tool("whoami", {})
        assert answer.content[0].text == principal  # type: ignore[union-attr]


@pytest.mark.parametrize("token", [None, "not-the-credential", BRAIN_TOKEN[:-1] + "x"])
async def test_a_missing_or_wrong_credential_is_a_401_never_a_crash(
    served: tuple[LaunchedProcess, str], token: str | None
) -> None:
    proc, url = served
    mark = len(proc.log().splitlines())
    async with httpx.AsyncClient(timeout=5.0) as http:
        if url.endswith("/sse"):
            opened = await http.get(url, headers=bearer(token))
            posted = await http.post(
                url.replace("/sse", "/messages/?session_id=0123456789abcdef"),
                headers=bearer(token),
                json={"jsonrpc": "2.0", "id": 1, "method": "tools/list"},
            )
        else:
            opened = await http.get(url, headers={**bearer(token), "accept": "text/event-stream"})
            posted = await http.post(
                url,
                headers={**bearer(token), "accept": "application/json, text/event-stream"},
                json={"jsonrpc": "2.0", "id": 1, "method": "tools/list"},
            )
    for answer in (opened, posted):
        assert answer.status_code == 401, answer.text
        challenge = answer.headers["www-authenticate"]
        assert challenge.startswith('Bearer realm="kit-proc"')
        assert ('error="invalid_token"' in challenge) == (token is not None)
        assert answer.json()["error"] in ("unauthorized", "invalid_token")
    with pytest.raises(BaseException) as refused:  # the SDK's own client is turned away too
        async with asyncio.timeout(10), Client(mcp_transport(url, token)) as client:
            await client.list_tools()
    if url.endswith("/sse"):  # streamable-http's client names no status, only an error
        assert "401" in " ".join(leaf_messages(refused.value))
    assert proc.running(), proc.log()

    def logged() -> list[dict[str, object]]:
        return [e for e in log_events(proc, mark) if e.get("event") == "mcp_auth_rejected"]

    wait_until(lambda: len(logged()) >= 3, 10, "three rejections logged")
    rejected = logged()
    assert {e["reason"] for e in rejected} == {"missing" if token is None else "invalid"}
    assert "Traceback" not in proc.log()
    for secret in (BRAIN_TOKEN, OPERATOR_TOKEN, "not-the-credential"):
        assert secret not in proc.log()


# over sse, the stack's transport (streamable-http's header path: the SDK client tests above)
@pytest.mark.parametrize("served", ["sse"], indirect=True)
def test_the_mcp_inspector_passes_the_operators_credential_as_a_header(
    served: tuple[LaunchedProcess, str], tmp_path: Path
) -> None:
    _, url = served
    listed = run_inspector([url], {}, tmp_path, headers=bearer(OPERATOR_TOKEN))
    assert listed.returncode == 0, listed.stderr[-2000:]
    assert {t["name"] for t in json.loads(listed.stdout)["tools"]} >= {"echo", "whoami"}
    refused = run_inspector([url], {}, tmp_path)
    assert refused.returncode != 0
    assert "401" in refused.stdout + refused.stderr


# the real process's refusal (the other unusable settings: test_kit_service_auth.py)
REFUSALS = [
    ({"MCP_AUTH_TOKEN": "short-" + BRAIN_TOKEN[:8]}, "MCP_AUTH_TOKEN is 14 bytes"),
    (
        {"MCP_AUTH_TOKEN": BRAIN_TOKEN, "MCP_APPROVAL_SECRET": "short-" + OPERATOR_TOKEN[:8]},
        "MCP_APPROVAL_SECRET is 14 bytes",
    ),
]


def test_an_http_server_without_a_usable_credential_refuses_to_start(
    launcher: ProcessLauncher,
) -> None:
    procs = [
        launcher.start(
            "refused",
            [sys.executable, str(PROC)],
            env={"MCP_TRANSPORT": "sse", "MCP_PORT": str(free_tcp_port()), **env},
        )
        for env, _ in REFUSALS
    ]
    for proc, (_, message) in zip(procs, REFUSALS, strict=True):
        assert proc.popen.wait(30) == 2, proc.log()
        output = proc.log().strip()
        assert output.splitlines() == [output]  # one line, no traceback
        assert message in output
        assert BRAIN_TOKEN[:8] not in output
        assert OPERATOR_TOKEN[:8] not in output


@pytest.mark.parametrize("transport", ["sse", "streamable-http"])
@pytest.mark.parametrize("stop", [signal.SIGINT, signal.SIGTERM])
async def test_a_normal_stop_with_a_client_connected_is_quiet_and_cleans_up(
    launcher: ProcessLauncher, transport: str, stop: signal.Signals
) -> None:
    """Issue 31: "Exception in ASGI application" (the SSE route's second response start) and
    interrupt tracebacks on every normal stop; a SIGTERM skipped the server's own cleanup."""
    port = free_tcp_port()
    proc = launcher.start(
        f"mcp-{transport}",
        [sys.executable, str(PROC)],
        env={
            "MCP_TRANSPORT": transport,
            "MCP_PORT": str(port),
            "LOG_LEVEL": "INFO",
            "MCP_AUTH_TOKEN": BRAIN_TOKEN,
        },
    )
    await asyncio.to_thread(wait_for_tcp_port, port, 20)
    url = f"http://127.0.0.1:{port}{PATHS[transport]}"
    with contextlib.suppress(Exception):  # the server goes away under the client
        async with Client(mcp_transport(url, BRAIN_TOKEN)) as client:
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
