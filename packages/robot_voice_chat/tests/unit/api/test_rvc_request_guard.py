"""The guard in front of the brain: trusted Host names (DNS rebinding), Origin on
state-changing requests and WebSockets (CSRF), no proxied requests while login is off, and a
Content-Security-Policy on every response."""

from __future__ import annotations

import asyncio
from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

import httpx
import pytest
import uvicorn
import websockets

from robot_mcp_kit.signing import signed_headers
from robot_stack_testing import async_wait_until, free_tcp_port
from robot_stack_testing.brain.harness import NAV_SECRET
from robot_voice_chat.api.app import create_app, create_asgi_app
from robot_voice_chat.api.container import Container
from robot_voice_chat.api.request_guard import host_name
from robot_voice_chat.composition import bootstrap, compose_config


def dev_container(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, *overrides: str) -> Container:
    monkeypatch.setenv("RVC_TRACE_DIR", str(tmp_path / "traces"))
    monkeypatch.setenv("NAV_EVENT_SECRET", NAV_SECRET)
    return bootstrap(compose_config("dev", list(overrides)))


@pytest.fixture
async def rest(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> AsyncIterator[httpx.AsyncClient]:
    app = create_app(dev_container(tmp_path, monkeypatch), manage_lifecycle=False)
    async with httpx.AsyncClient(
        transport=httpx.ASGITransport(app), base_url="http://127.0.0.1:8000"
    ) as client:
        yield client


@pytest.mark.parametrize(
    ("header", "name"),
    [
        ("127.0.0.1:8000", "127.0.0.1"),
        ("LOCALHOST", "localhost"),
        ("[::1]:8000", "::1"),
        ("::1", "::1"),
        ("evil.example:8000", "evil.example"),
    ],
)
def test_host_names_are_read_without_the_port(header: str, name: str) -> None:
    assert host_name(header) == name


async def test_a_foreign_host_is_refused_for_rest(rest: httpx.AsyncClient) -> None:
    refused = await rest.post(
        "/api/chat/stop",
        headers={"Host": "evil.example:8000", "Origin": "http://evil.example:8000"},
    )
    assert refused.status_code == 400
    assert refused.json()["reason"] == "untrusted_host"
    assert (await rest.get("/api/livez", headers={"Host": "evil.example"})).status_code == 400
    for host in ("127.0.0.1:8000", "localhost:8000", "[::1]:8000"):
        assert (await rest.get("/api/livez", headers={"Host": host})).status_code == 200


async def test_a_foreign_origin_cannot_change_state(rest: httpx.AsyncClient) -> None:
    forged = await rest.post(
        "/api/chat/stop",
        content=b"stop",
        headers={"Origin": "https://evil.example", "Content-Type": "text/plain"},
    )
    assert forged.status_code == 403
    assert forged.json()["reason"] == "foreign_origin"
    null = await rest.post(
        "/api/agent/teaching", json={"enabled": True}, headers={"Origin": "null"}
    )
    assert null.status_code == 403
    # reading is not state-changing; the served UI (same origin) and machines (no Origin) may
    assert (await rest.get("/api/livez", headers={"Origin": "https://evil.example"})).is_success
    same = await rest.post("/api/chat/stop", headers={"Origin": "http://127.0.0.1:8000"})
    assert same.json() == {"status": "stopped"}
    assert (await rest.post("/api/chat/stop")).json() == {"status": "stopped"}


async def test_the_signed_event_route_still_works_without_an_origin(
    rest: httpx.AsyncClient,
) -> None:
    raw = (
        b'{"schema_version":1,"event_id":"e-1","task_id":"nav-1","server":"navigation",'
        b'"tool":"navigate_to","type":"progress","seq":0,"ts":1.0,"payload":{}}'
    )
    answer = await rest.post(
        "/api/agent/events", content=raw, headers=signed_headers("navigation", NAV_SECRET, raw)
    )
    assert answer.status_code == 200, answer.text
    assert answer.json() == {"status": "orphan"}


@pytest.mark.parametrize(
    "header",
    [
        {"X-Forwarded-For": "192.168.1.20"},
        {"Forwarded": "for=192.168.1.20;proto=https"},
        {"X-Real-IP": "192.168.1.20"},
    ],
)
async def test_with_login_off_a_request_through_a_proxy_is_refused(
    rest: httpx.AsyncClient, header: dict[str, str]
) -> None:
    refused = await rest.get("/api/agent/missions", headers=header)
    assert refused.status_code == 403
    assert refused.json()["reason"] == "proxied_without_login"
    assert (await rest.get("/api/agent/missions")).status_code == 200


async def test_every_response_carries_a_content_security_policy(rest: httpx.AsyncClient) -> None:
    for path in ("/api/livez", "/api/agent/missions", "/no-such-page"):
        response = await rest.get(path)
        policy = response.headers["content-security-policy"]
        assert "default-src 'self'" in policy
        assert "script-src 'self'" in policy
        assert "frame-ancestors 'none'" in policy
        assert response.headers["x-content-type-options"] == "nosniff"


@pytest.fixture
async def served(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> AsyncIterator[int]:
    port = free_tcp_port()
    for name in ("NAVIGATION", "MANIPULATION", "MEMORY", "SKILL_CONTROL", "PERCEPTION"):
        monkeypatch.setenv(f"RVC_{name}_URL", "http://127.0.0.1:9/sse")  # nothing there
    app: Any = create_asgi_app(dev_container(tmp_path, monkeypatch))
    server = uvicorn.Server(uvicorn.Config(app, host="127.0.0.1", port=port, log_level="warning"))
    serving = asyncio.create_task(server.serve())
    await async_wait_until(lambda: server.started, 10, "app serving")
    yield port
    server.should_exit = True
    async with asyncio.timeout(15):
        await serving


async def test_a_dns_rebinding_page_cannot_open_a_socket_or_post(served: int) -> None:
    rebound = {"Host": f"evil.example:{served}", "Origin": f"http://evil.example:{served}"}
    async with httpx.AsyncClient(base_url=f"http://127.0.0.1:{served}") as http:
        polling = await http.get("/socket.io/?EIO=4&transport=polling", headers=rebound)
        assert polling.status_code == 400
        chat = await http.post("/api/chat", json={"text": "go to the kitchen"}, headers=rebound)
        assert chat.status_code == 400
        assert (await http.get("/socket.io/?EIO=4&transport=polling")).status_code == 200
    with pytest.raises(websockets.InvalidStatus):
        await websockets.connect(
            f"ws://127.0.0.1:{served}/socket.io/?EIO=4&transport=websocket",
            additional_headers=rebound,
        )
    with pytest.raises(websockets.InvalidStatus):  # the Host is fine, the page is foreign
        await websockets.connect(
            f"ws://127.0.0.1:{served}/socket.io/?EIO=4&transport=websocket",
            origin=websockets.Origin("https://evil.example"),
        )
    ws = await websockets.connect(f"ws://127.0.0.1:{served}/socket.io/?EIO=4&transport=websocket")
    assert str(await ws.recv()).startswith("0")
    await ws.close()
