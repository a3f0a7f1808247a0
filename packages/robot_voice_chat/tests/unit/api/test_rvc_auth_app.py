"""The served app with operator login on: REST, Socket.IO and the login flow over real HTTP."""

from __future__ import annotations

import asyncio
import json
import shutil
import tempfile
import time
from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

import httpx
import pytest
import structlog
import structlog.testing
import uvicorn
import websockets

from robot_stack_testing import async_wait_until, free_tcp_port
from robot_voice_chat.api.app import create_app, create_asgi_app
from robot_voice_chat.api.auth import hash_password
from robot_voice_chat.api.container import Container
from robot_voice_chat.api.forwarded import unix_listener
from robot_voice_chat.composition import bootstrap, compose_config
from robot_voice_chat.main import server_config
from robot_voice_chat.socket_events import MissionEventLine

PASSWORD = "open sesame 42"
HASH = hash_password(PASSWORD)


@pytest.fixture
async def served(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> AsyncIterator[tuple[str, Container]]:
    async for address, _, container in serve(tmp_path, monkeypatch):
        yield address, container


@pytest.fixture
async def served_with_proxy(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> AsyncIterator[tuple[str, Path, Container]]:
    """Also listening on the proxy's Unix socket, as ``robot-voice-chat --proxy-socket``."""
    async for served_at in serve(tmp_path, monkeypatch, proxy_socket=True):
        yield served_at


async def serve(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, proxy_socket: bool = False
) -> AsyncIterator[tuple[str, Path, Container]]:
    """The brain served like ``main`` serves it (TCP, and the proxy socket if asked)."""
    port = free_tcp_port()
    monkeypatch.setenv("RVC_TRACE_DIR", str(tmp_path / "traces"))
    for name in ("NAVIGATION", "MANIPULATION", "MEMORY", "SKILL_CONTROL", "PERCEPTION"):
        monkeypatch.setenv(f"RVC_{name}_URL", "http://127.0.0.1:9/sse")  # nothing there
    monkeypatch.setenv("ADMIN_USERNAME", "ada")
    monkeypatch.setenv("ADMIN_PASSWORD_HASH", HASH)
    monkeypatch.setenv("ADMIN_SECRET_KEY", "s" * 48)
    config = compose_config("test", ["auth.enabled=true", "+auth.login_max_failures=3"])
    container = bootstrap(config)
    server = uvicorn.Server(server_config(create_asgi_app(container), "127.0.0.1", port))
    socket_dir = Path(tempfile.mkdtemp(prefix="rvc-", dir="/tmp"))  # short: sun_path limit
    path = socket_dir / "proxy.sock"
    sockets = [server.config.bind_socket()]
    if proxy_socket:
        sockets.append(unix_listener(path))
    serving = asyncio.create_task(server.serve(sockets=sockets))
    try:
        await async_wait_until(lambda: server.started, 10, "app serving")
        yield f"127.0.0.1:{port}", path, container
    finally:
        server.should_exit = True
        await asyncio.wait_for(serving, 15)
        shutil.rmtree(socket_dir, ignore_errors=True)


async def login(http: httpx.AsyncClient, password: str = PASSWORD) -> httpx.Response:
    return await http.post("/api/auth/login", json={"username": "ada", "password": password})


async def test_rest_without_a_session_gets_401_but_health_stays_public(
    served: tuple[str, Container],
) -> None:
    address, _ = served
    async with httpx.AsyncClient(base_url=f"http://{address}") as http:
        for path in ("/api/agent/missions", "/api/agent/teaching", "/api/history", "/openapi.json"):
            response = await http.get(path)
            assert response.status_code == 401, path
            assert response.json() == {"detail": "login required"}
        assert (await http.post("/api/agent/teaching", json={"enabled": True})).status_code == 401
        assert (await http.get("/api/livez")).status_code == 200
        assert (await http.get("/api/readyz")).status_code == 200
        assert (await http.get("/api/auth/me")).status_code == 401
        # the signed ingress keeps its own HMAC check (its own 401, not the login's)
        ingress = await http.post("/api/agent/events", content=b"{}")
        assert ingress.status_code == 401
        assert ingress.json() == {"status": "rejected", "reason": "unauthorized"}


async def test_login_sets_a_strict_httponly_expiring_cookie_and_the_api_works(
    served: tuple[str, Container],
) -> None:
    address, _ = served
    async with httpx.AsyncClient(base_url=f"http://{address}") as http:
        response = await login(http)
        assert response.status_code == 200
        assert response.json() == {"auth_enabled": True, "operator": "ada"}
        cookie = response.headers["set-cookie"].lower()
        assert "httponly" in cookie
        assert "samesite=strict" in cookie
        assert "max-age=43200" in cookie
        assert "secure" not in cookie  # plain http on loopback; see the proxy test
        assert (await http.get("/api/auth/me")).json()["operator"] == "ada"
        teaching = await http.post("/api/agent/teaching", json={"enabled": True})
        assert teaching.json() == {"enabled": True}
        assert (await http.get("/api/agent/missions")).status_code == 200
        await http.post("/api/auth/logout")
        assert (await http.get("/api/agent/missions")).status_code == 401


def via_proxy(path: Path) -> httpx.AsyncClient:
    """A client on the proxy socket, as Caddy connects (the Host is the robot's)."""
    transport = httpx.AsyncHTTPTransport(uds=str(path))
    return httpx.AsyncClient(transport=transport, base_url="http://localhost")


async def test_the_cookie_is_secure_behind_a_tls_proxy(
    served_with_proxy: tuple[str, Path, Container],
) -> None:
    _, path, _ = served_with_proxy
    async with via_proxy(path) as http:
        response = await http.post(
            "/api/auth/login",
            json={"username": "ada", "password": PASSWORD},
            headers={"X-Forwarded-Proto": "https", "X-Forwarded-For": "10.1.2.3"},
        )
        assert "secure" in response.headers["set-cookie"].lower()


async def test_forwarded_addresses_from_a_local_client_do_not_dodge_the_login_throttle(
    served_with_proxy: tuple[str, Path, Container],
) -> None:
    """Issue 31: 30 wrong logins from 127.0.0.1, each with a new X-Forwarded-For → no 429."""
    address, path, _ = served_with_proxy
    wrong = {"username": "ada", "password": "wrong"}
    async with httpx.AsyncClient(base_url=f"http://{address}") as local:
        statuses = [
            (
                await local.post(
                    "/api/auth/login",
                    json=wrong,
                    headers={"X-Forwarded-For": f"10.9.0.{i}", "X-Forwarded-Proto": "https"},
                )
            ).status_code
            for i in range(30)
        ]
        assert statuses[:3] == [401] * 3
        assert set(statuses[3:]) == {429}  # one address: this connection's own
        right = await local.post(
            "/api/auth/login",
            json={"username": "ada", "password": PASSWORD},
            headers={"X-Forwarded-For": "10.9.9.9"},
        )
        assert right.status_code == 429
    # through the proxy socket the forwarded address is the client's: others may still log in
    async with via_proxy(path) as proxy:
        login = await proxy.post(
            "/api/auth/login",
            json={"username": "ada", "password": PASSWORD},
            headers={"X-Forwarded-For": "10.1.2.3", "X-Forwarded-Proto": "https"},
        )
        assert login.status_code == 200, login.text


async def test_an_old_session_does_not_survive_logout(served: tuple[str, Container]) -> None:
    address, _ = served
    async with httpx.AsyncClient(base_url=f"http://{address}") as http:
        token = (await login(http)).cookies["rvc_session"]
        await http.post("/api/auth/logout")
    async with httpx.AsyncClient(
        base_url=f"http://{address}", cookies={"rvc_session": token}
    ) as replay:
        assert (await replay.get("/api/agent/missions")).status_code == 401


async def test_wrong_passwords_are_rate_limited_per_address_and_never_logged(
    served: tuple[str, Container], capsys: pytest.CaptureFixture[str]
) -> None:
    address, _ = served
    async with httpx.AsyncClient(base_url=f"http://{address}") as http:
        statuses = [(await login(http, "wrong-guess")).status_code for _ in range(3)]
        assert statuses == [401, 401, 401]
        throttled = await login(http)  # even the right password waits now
        assert throttled.status_code == 429
        assert int(throttled.headers["retry-after"]) > 0
    assert "wrong-guess" not in capsys.readouterr().err


async def test_socketio_connect_is_refused_without_a_session(
    served: tuple[str, Container],
) -> None:
    address, _ = served
    async with httpx.AsyncClient(base_url=f"http://{address}") as http:
        polling = await http.get("/socket.io/", params={"EIO": "4", "transport": "polling"})
        assert polling.status_code == 401
    with pytest.raises(websockets.InvalidStatus):
        await websockets.connect(f"ws://{address}/socket.io/?EIO=4&transport=websocket")


async def socket_connect(address: str, cookie: str) -> Any:
    ws = await websockets.connect(
        f"ws://{address}/socket.io/?EIO=4&transport=websocket",
        additional_headers={"Cookie": f"rvc_session={cookie}"},
    )
    assert str(await ws.recv()).startswith("0")
    await ws.send("40")
    return ws


async def test_a_logged_in_socket_starts_a_mission_whose_trace_names_the_operator(
    served: tuple[str, Container],
) -> None:
    address, container = served
    async with httpx.AsyncClient(base_url=f"http://{address}") as http:
        cookie = (await login(http)).cookies["rvc_session"]
    ws = await socket_connect(address, cookie)
    try:
        await ws.send(
            "42"
            + json.dumps(["send_message", {"text": "Please fetch the package from the mailroom."}])
        )
        await async_wait_until(lambda: container.executor.store.recent(1), 10, "mission started")
        mission = container.executor.store.recent(1)[0]

        async def instruction_traced() -> list[dict[str, Any]]:
            return [r for r in await container.trace.read(mission.id) if r["kind"] == "instruction"]

        traced = await async_wait_until(instruction_traced, 10, "the instruction traced")
        assert traced[0]["operator"] == "ada"
    finally:
        await ws.close()


async def test_without_auth_the_api_is_open_and_login_is_not_offered(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("RVC_TRACE_DIR", str(tmp_path / "traces"))
    container = bootstrap(compose_config("dev"))
    assert container.auth is None
    app = create_app(container, manage_lifecycle=False)
    async with httpx.AsyncClient(
        transport=httpx.ASGITransport(app), base_url="http://127.0.0.1"
    ) as http:
        assert (await http.get("/api/agent/missions")).status_code == 200
        assert (await http.get("/api/auth/me")).json() == {
            "auth_enabled": False,
            "operator": None,
        }
        refused = await http.post("/api/auth/login", json={"username": "a", "password": "b"})
        assert refused.status_code == 404
        assert (await http.post("/api/auth/logout")).status_code == 200


async def test_sixty_parallel_logins_from_one_address_are_throttled(
    served: tuple[str, Container],
) -> None:
    address, _ = served
    limits = httpx.Limits(max_connections=60)
    async with httpx.AsyncClient(base_url=f"http://{address}", limits=limits, timeout=60) as http:
        responses = await asyncio.gather(*(login(http, f"guess-{i}") for i in range(60)))
    statuses = [r.status_code for r in responses]
    assert statuses.count(401) == 3  # login_max_failures: only three passwords were checked
    assert statuses.count(429) == 57


async def test_the_right_password_last_of_forty_parallel_attempts_is_not_accepted(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("ADMIN_USERNAME", "ada")
    monkeypatch.setenv("ADMIN_PASSWORD_HASH", HASH)
    monkeypatch.setenv("ADMIN_SECRET_KEY", "s" * 48)
    container = bootstrap(compose_config("test", ["auth.enabled=true"]))
    app = create_app(container, manage_lifecycle=False)
    transport = httpx.ASGITransport(app)  # one client address; requests start in order
    async with httpx.AsyncClient(transport=transport, base_url="http://127.0.0.1") as http:
        attempts = [login(http, f"guess-{i}") for i in range(39)] + [login(http)]
        statuses = [r.status_code for r in await asyncio.gather(*attempts)]
    assert statuses[:5] == [401] * 5  # the robot preset's five tries were checked
    assert statuses[5:] == [429] * 35  # the right password came after the budget was spent


async def read_until_closed(ws: Any) -> list[str]:
    """Frames until Engine.IO's close packet ("1") or the end of the connection."""
    frames: list[str] = []
    async with asyncio.timeout(10):
        try:
            while not frames or frames[-1] != "1":
                frames.append(str(await ws.recv()))
        except websockets.ConnectionClosed:
            pass
    return frames


def socket_ids(frames: list[str]) -> list[str]:
    return [json.loads(f[2:])["sid"] for f in frames if f.startswith("40{")]


def connected(container: Container, sid: str) -> bool:
    return bool(container.sio.manager.is_connected(sid, "/"))


async def test_an_open_socket_is_closed_at_logout_and_cannot_send_afterwards(
    served: tuple[str, Container],
) -> None:
    address, container = served
    async with httpx.AsyncClient(base_url=f"http://{address}") as http:
        cookie = (await login(http)).cookies["rvc_session"]
        ws = await socket_connect(address, cookie)
        other = await socket_connect(address, (await login(http)).cookies["rvc_session"])
        try:
            async with httpx.AsyncClient(
                base_url=f"http://{address}", cookies={"rvc_session": cookie}
            ) as same_session:
                assert (await same_session.post("/api/auth/logout")).status_code == 200
            frames = await read_until_closed(ws)
            assert frames[-2:] == ["41", "1"]  # Socket.IO disconnect, then Engine.IO close
            (sid,) = socket_ids(frames)
            assert not connected(container, sid)
            # another session's socket stays open and works
            await other.send("421" + json.dumps(["stop_pipeline"]))
            async with asyncio.timeout(10):
                while not str(reply := await other.recv()).startswith("431"):
                    pass
            assert json.loads(str(reply)[3:]) == [{"ok": True}]
        finally:
            await ws.close()
            await other.close()
    assert container.executor.store.recent(1) == []


async def test_an_expired_session_s_socket_refuses_events_and_is_closed(
    served: tuple[str, Container],
) -> None:
    address, container = served
    async with httpx.AsyncClient(base_url=f"http://{address}") as http:
        cookie = (await login(http)).cookies["rvc_session"]
    ws = await socket_connect(address, cookie)
    async with asyncio.timeout(10):
        while not (joined := str(await ws.recv())).startswith("40{"):
            pass
    (sid,) = socket_ids([joined])
    auth = container.auth
    assert auth is not None
    ttl = auth.config.session_ttl_s
    auth.clock = lambda: time.time() + ttl + 1  # the session has expired since the connect
    try:
        await ws.send("421" + json.dumps(["send_message", {"text": "Go to the kitchen."}]))
        frames = await read_until_closed(ws)
        assert '431[{"ok":false,"error":"login required"}]' in frames
        assert frames[-2:] == ["41", "1"]
        assert not connected(container, sid)
    finally:
        await ws.close()
    assert container.executor.store.recent(1) == []


async def test_a_failed_login_does_not_log_the_typed_user_name(
    served: tuple[str, Container],
) -> None:
    address, _ = served
    with structlog.testing.capture_logs() as logs:
        async with httpx.AsyncClient(base_url=f"http://{address}") as http:
            typed = {"username": "hunter2-typed-in-the-wrong-box", "password": "x"}
            assert (await http.post("/api/auth/login", json=typed)).status_code == 401
    assert [e for e in logs if e["event"] == "login_failed"]
    assert "hunter2-typed-in-the-wrong-box" not in repr(logs)


def login_app(monkeypatch: pytest.MonkeyPatch) -> Any:
    monkeypatch.setenv("ADMIN_USERNAME", "ada")
    monkeypatch.setenv("ADMIN_PASSWORD_HASH", HASH)
    monkeypatch.setenv("ADMIN_SECRET_KEY", "s" * 48)
    return create_app(
        bootstrap(compose_config("test", ["auth.enabled=true"])), manage_lifecycle=False
    )


async def test_a_huge_login_body_is_refused_unread_and_never_echoed(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Issue 31: a 200 MB POST to /api/auth/login came back as a 422 carrying 200 MiB."""
    sent = 0
    chunk = b'{"username": "' + b"a" * (1 << 20)

    async def body() -> AsyncIterator[bytes]:
        nonlocal sent
        for _ in range(200):  # 200 MiB if it were all read
            sent += len(chunk)
            yield chunk

    transport = httpx.ASGITransport(login_app(monkeypatch))
    async with httpx.AsyncClient(transport=transport, base_url="http://127.0.0.1") as http:
        streamed = await http.post("/api/auth/login", content=body())
        declared = await http.post(
            "/api/auth/login",
            content=b"{}",
            headers={"Content-Length": str(200 << 20), "Content-Type": "application/json"},
        )
    assert streamed.status_code == 413, streamed.text[:200]
    assert len(streamed.content) < 1000
    assert sent <= 2 * len(chunk)  # it stopped reading at the limit
    assert declared.status_code == 413


async def test_a_login_the_schema_refuses_does_not_echo_what_was_sent(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    transport = httpx.ASGITransport(login_app(monkeypatch))
    async with httpx.AsyncClient(transport=transport, base_url="http://127.0.0.1") as http:
        refused = await http.post(
            "/api/auth/login", json={"username": "ada", "password": ["my-real-password-1"]}
        )
    assert refused.status_code == 422
    assert "my-real-password-1" not in refused.text
    assert refused.json()["detail"][0]["loc"] == ["body", "password"]


async def test_logout_answers_with_an_idle_polling_socket_and_closes_the_websocket(
    served: tuple[str, Container],
) -> None:
    """Issue 31: an idle long-polling Socket.IO connection of the session stalled the logout
    (200 s), and the session's websocket kept receiving events."""
    address, container = served
    async with httpx.AsyncClient(base_url=f"http://{address}", timeout=10) as http:
        cookie = (await login(http)).cookies["rvc_session"]  # the client keeps it
        opened = await http.get("/socket.io/?EIO=4&transport=polling")
        assert opened.status_code == 200, opened.text
        eio_sid = json.loads(opened.text[1:])["sid"]
        poll = f"/socket.io/?EIO=4&transport=polling&sid={eio_sid}"
        assert (await http.post(poll, content="40")).status_code == 200
        assert "40{" in (await http.get(poll)).text  # joined; now idle
        ws = await socket_connect(address, cookie)
        try:
            async with asyncio.timeout(10):
                while not str(await ws.recv()).startswith("40{"):
                    pass
            async with asyncio.timeout(15):  # was: no answer for 200 s
                out = await http.post("/api/auth/logout")
            assert out.status_code == 200
            await container.emitter.emit(
                MissionEventLine(mission_id="m-x", kind="say", text="hi", ts=time.time())
            )
            frames = await read_until_closed(ws)
            assert not [f for f in frames if "mission_event" in f]
            assert frames[-2:] == ["41", "1"]
        finally:
            await ws.close()
