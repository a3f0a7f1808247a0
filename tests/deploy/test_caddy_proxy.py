"""deploy/Caddyfile (RUNBOOK step 4) with Debian's caddy in front of a real brain, on loopback.

The shipped file is used as is, with three test-only changes: the site address comes from
ROBOT_HOSTNAME (as the file documents), the upstream port is the brain's free port instead of
8000, and a global options block keeps Caddy off the fixed ports 80/443 and off the system
trust store (``skip_install_trust``; its local CA lives in the test's temp dir). Nothing leaves
loopback: ``tls internal`` issues the certificate locally, no ACME.
"""

from __future__ import annotations

import asyncio
import secrets
import shutil
import ssl
import subprocess
import sys
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import httpx
import pytest
import socketio

from robot_stack_testing import ProcessLauncher, free_tcp_port, wait_for_tcp_port, wait_until
from robot_voice_chat.api.auth import hash_password
from robot_voice_chat.api.security_headers import CONTENT_SECURITY_POLICY

ROOT = Path(__file__).resolve().parents[2]
CADDYFILE = ROOT / "deploy" / "Caddyfile"
PASSWORD = "caddy-test operator password"


@pytest.fixture(scope="module")
def caddy() -> str:
    found = shutil.which("caddy")
    assert found, "caddy is not installed: make setup installs it (apt-get install caddy)"
    return found


def caddy_env(tmp_path: Path, **extra: str) -> dict[str, str]:
    """Caddy's data (its local CA) and config dirs inside the test's temp dir."""
    return {
        "HOME": str(tmp_path),
        "XDG_DATA_HOME": str(tmp_path / "caddy-data"),
        "XDG_CONFIG_HOME": str(tmp_path / "caddy-config"),
        **extra,
    }


def test_the_shipped_caddyfile_is_valid(caddy: str, tmp_path: Path) -> None:
    result = subprocess.run(
        [caddy, "validate", "--config", str(CADDYFILE), "--adapter", "caddyfile"],
        env={"PATH": "/usr/bin:/bin", **caddy_env(tmp_path)},
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert result.returncode == 0, result.stderr
    assert "Valid configuration" in result.stdout + result.stderr


@dataclass
class Proxied:
    https: str  # the site through Caddy
    http: str  # Caddy's plain-HTTP port (redirects)
    brain: str  # the brain directly, bypassing Caddy
    root_ca: Path  # Caddy's local CA certificate (what operators install once)


@pytest.fixture
def proxied(caddy: str, tmp_path: Path) -> Iterator[Proxied]:
    brain_port, https_port, http_port = free_tcp_port(), free_tcp_port(), free_tcp_port()
    shipped = CADDYFILE.read_text(encoding="utf-8")
    assert "reverse_proxy 127.0.0.1:8000" in shipped
    config = tmp_path / "Caddyfile"
    config.write_text(
        "{\n\tadmin off\n\tskip_install_trust\n"
        f"\thttp_port {http_port}\n\thttps_port {https_port}\n}}\n\n"
        + shipped.replace("127.0.0.1:8000", f"127.0.0.1:{brain_port}"),
        encoding="utf-8",
    )
    dead = f"http://127.0.0.1:{free_tcp_port()}"
    brain_env = {
        "RVC_DEPLOYMENT": "dev",
        "RVC_TRACE_DIR": str(tmp_path / "missions"),
        "RVC_DATA_DIR": str(tmp_path / "brain"),
        "RVC_CAMERA_URL": dead,
        "ADMIN_PASSWORD_HASH": hash_password(PASSWORD),
        "ADMIN_SECRET_KEY": secrets.token_urlsafe(32),
        **{
            f"RVC_{s}_URL": f"{dead}/sse"
            for s in ("NAVIGATION", "MANIPULATION", "MEMORY", "SKILL_CONTROL", "PERCEPTION")
        },
    }
    launcher = ProcessLauncher(tmp_path)
    try:
        brain = launcher.start(
            "brain",
            [
                sys.executable,
                "-m",
                "robot_voice_chat",
                "--port",
                str(brain_port),
                "auth.enabled=true",
            ],
            brain_env,
        )
        proxy = launcher.start(
            "caddy",
            [caddy, "run", "--config", str(config), "--adapter", "caddyfile"],
            caddy_env(tmp_path, ROBOT_HOSTNAME=f"localhost:{https_port}"),
        )
        wait_for_tcp_port(brain_port, 60.0)
        wait_for_tcp_port(https_port, 30.0)
        assert brain.running(), brain.log()
        assert proxy.running(), proxy.log()
        root_ca = tmp_path / "caddy-data/caddy/pki/authorities/local/root.crt"
        wait_until(root_ca.is_file, 30.0, "Caddy's local CA")
        yield Proxied(
            https=f"https://localhost:{https_port}",
            http=f"http://localhost:{http_port}",
            brain=f"http://127.0.0.1:{brain_port}",
            root_ca=root_ca,
        )
    finally:
        launcher.stop_all()


def https_client(proxied: Proxied) -> httpx.Client:
    trust = ssl.create_default_context(cafile=str(proxied.root_ca))
    return httpx.Client(base_url=proxied.https, verify=trust, timeout=10)


def test_the_brain_answers_over_https_with_the_security_headers(proxied: Proxied) -> None:
    with https_client(proxied) as client:
        live = client.get("/api/livez")
        page = client.get("/")
    assert live.status_code == 200, live.text
    assert live.json() == {"status": "ok"}
    assert page.status_code == 200
    assert page.headers["strict-transport-security"] == "max-age=31536000"
    assert page.headers["x-frame-options"] == "DENY"
    assert page.headers["x-content-type-options"] == "nosniff"
    assert page.headers["referrer-policy"] == "no-referrer"
    assert "server" not in page.headers
    assert page.headers["content-security-policy"] == CONTENT_SECURITY_POLICY


def test_the_event_ingress_and_readiness_details_are_not_published(proxied: Proxied) -> None:
    with https_client(proxied) as client:
        for path in ("/api/agent/events", "/api/readyz", "/API/ReadyZ", "/api/agent/events/"):
            answer = client.post(path) if "events" in path else client.get(path)
            assert answer.status_code == 404, path
            assert "mcp_servers" not in answer.text
        assert client.get("/api/livez").status_code == 200
    # on the robot itself both still answer (the servers post their events here)
    assert httpx.get(f"{proxied.brain}/api/readyz", timeout=10).status_code == 200
    assert httpx.post(f"{proxied.brain}/api/agent/events", timeout=10).status_code == 401


def test_plain_http_is_redirected_to_https(proxied: Proxied) -> None:
    answer = httpx.get(f"{proxied.http}/api/livez", timeout=10, follow_redirects=False)
    assert answer.status_code in (301, 308), answer.text
    # to the site's host on the HTTPS port (443 on a robot; Caddy leaves the default port out)
    assert answer.headers["location"].startswith("https://localhost")
    assert answer.headers["location"].endswith("/api/livez")


def test_a_login_through_the_proxy_sets_a_secure_cookie_and_a_direct_one_does_not(
    proxied: Proxied,
) -> None:
    credentials = {"username": "operator", "password": PASSWORD}
    with https_client(proxied) as client:
        proxied_login = client.post("/api/auth/login", json=credentials)
        assert proxied_login.status_code == 200, proxied_login.text
        assert client.get("/api/auth/me").json()["operator"] == "operator"
    direct = httpx.post(f"{proxied.brain}/api/auth/login", json=credentials, timeout=10)
    assert direct.status_code == 200, direct.text
    # the brain believes X-Forwarded-Proto from Caddy on 127.0.0.1 (auth.trusted_proxies)
    assert "secure" in proxied_login.headers["set-cookie"].lower()
    assert "secure" not in direct.headers["set-cookie"].lower()


def test_socketio_upgrades_to_a_websocket_through_the_proxy(proxied: Proxied) -> None:
    with https_client(proxied) as client:
        login = client.post("/api/auth/login", json={"username": "operator", "password": PASSWORD})
        assert login.status_code == 200, login.text
        cookie = "; ".join(f"{k}={v}" for k, v in client.cookies.items())

    async def connect() -> str:
        sio = socketio.AsyncClient(ssl_verify=False)  # the CA is checked by the HTTP tests
        await sio.connect(
            proxied.https,
            transports=["websocket"],
            headers={"Cookie": cookie},
            wait_timeout=10,
        )
        try:
            return str(sio.transport())
        finally:
            await sio.disconnect()

    assert asyncio.run(connect()) == "websocket"


def test_socketio_without_a_session_is_refused_through_the_proxy(proxied: Proxied) -> None:
    handshake = "/socket.io/?EIO=4&transport=polling"
    with https_client(proxied) as client:
        refused = client.get(handshake)
        client.post("/api/auth/login", json={"username": "operator", "password": PASSWORD})
        accepted = client.get(handshake)
    assert refused.status_code == 401, refused.text
    assert accepted.status_code == 200, accepted.text
