"""deploy/Caddyfile (RUNBOOK step 4) with Debian's caddy in front of a real brain, on loopback.

The shipped file is used as is, with three test-only changes: the site address comes from
ROBOT_HOSTNAME (as the file documents), the upstream is the test brain's proxy socket instead of
/run/robot-voice-chat/proxy.sock, and a global options block keeps Caddy off the fixed ports
80/443 and off the system trust store (``skip_install_trust``; its local CA lives in the test's
temp dir). Nothing leaves loopback: ``tls internal`` issues the certificate locally, no ACME.

The robot's name is not a loopback name (``robot-7.test``, as an operator's LAN name would be),
and the brain runs the robot preset's host and proxy settings, so a name the brain does not
trust, or forwarded headers it does not believe, fail here as they would on a robot. Requests
go to 127.0.0.1 with that name in the Host header and the TLS server name (no DNS needed).
"""

from __future__ import annotations

import asyncio
import gc
import secrets
import shutil
import ssl
import subprocess
import sys
import tempfile
import warnings
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
SHIPPED_UPSTREAM = "unix//run/robot-voice-chat/proxy.sock"
PASSWORD = "caddy-test operator password"
ROBOT = "robot-7.test"  # the robot's LAN name: not localhost, not an address


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
    https: str  # the site through Caddy (127.0.0.1; the robot's name goes in Host and SNI)
    http: str  # Caddy's plain-HTTP port (redirects)
    host: str  # the site's Host header: the robot's name and Caddy's HTTPS port
    brain: str  # the brain directly, bypassing Caddy
    root_ca: Path  # Caddy's local CA certificate (what operators install once)


@pytest.fixture
def socket_dir() -> Iterator[Path]:
    path = Path(tempfile.mkdtemp(prefix="rvc-", dir="/tmp"))  # sun_path is 108 bytes
    yield path
    shutil.rmtree(path, ignore_errors=True)


@pytest.fixture
def proxied(caddy: str, tmp_path: Path, socket_dir: Path) -> Iterator[Proxied]:
    brain_port, https_port, http_port = free_tcp_port(), free_tcp_port(), free_tcp_port()
    proxy_socket = socket_dir / "proxy.sock"
    shipped = CADDYFILE.read_text(encoding="utf-8")
    assert f"reverse_proxy {SHIPPED_UPSTREAM}" in shipped
    config = tmp_path / "Caddyfile"
    config.write_text(
        "{\n\tadmin off\n\tskip_install_trust\n"
        f"\thttp_port {http_port}\n\thttps_port {https_port}\n\tdefault_sni {ROBOT}\n}}\n\n"
        + shipped.replace(SHIPPED_UPSTREAM, f"unix/{proxy_socket}"),
        encoding="utf-8",
    )
    dead = f"http://127.0.0.1:{free_tcp_port()}"
    brain_env = {
        # the robot preset's host names, login and proxy trust; offline adapters, no keys
        "RVC_DEPLOYMENT": "robot",
        "RVC_CONFIG_OVERRIDES": "llm=rules llm_planner=rules speech_output=socketio "
        "speech_input=none tools.require_event_secrets=false tools.require_mcp_credentials=false",
        "ROBOT_HOSTNAME": ROBOT,
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
                "--proxy-socket",
                str(proxy_socket),
            ],
            brain_env,
        )
        proxy = launcher.start(
            "caddy",
            [caddy, "run", "--config", str(config), "--adapter", "caddyfile"],
            caddy_env(tmp_path, ROBOT_HOSTNAME=f"{ROBOT}:{https_port}"),
        )
        wait_for_tcp_port(brain_port, 60.0)
        wait_for_tcp_port(https_port, 30.0)
        assert brain.running(), brain.log()
        assert proxy.running(), proxy.log()
        root_ca = tmp_path / "caddy-data/caddy/pki/authorities/local/root.crt"
        wait_until(root_ca.is_file, 30.0, "Caddy's local CA")
        yield Proxied(
            https=f"https://127.0.0.1:{https_port}",
            http=f"http://127.0.0.1:{http_port}",
            host=f"{ROBOT}:{https_port}",
            brain=f"http://127.0.0.1:{brain_port}",
            root_ca=root_ca,
        )
    finally:
        launcher.stop_all()


class RobotNameTransport(httpx.HTTPTransport):
    """Connects to 127.0.0.1 but names the robot in TLS (SNI, certificate check)."""

    def handle_request(self, request: httpx.Request) -> httpx.Response:
        request.extensions["sni_hostname"] = ROBOT
        return super().handle_request(request)


def https_client(proxied: Proxied) -> httpx.Client:
    trust = ssl.create_default_context(cafile=str(proxied.root_ca))
    return httpx.Client(
        base_url=proxied.https,
        headers={"Host": proxied.host},
        transport=RobotNameTransport(verify=trust),
        timeout=10,
    )


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
    port = proxied.http.rsplit(":", 1)[1]
    answer = httpx.get(
        f"{proxied.http}/api/livez",
        headers={"Host": f"{ROBOT}:{port}"},
        timeout=10,
        follow_redirects=False,
    )
    assert answer.status_code in (301, 308), answer.text
    # to the site's host on the HTTPS port (443 on a robot; Caddy leaves the default port out)
    assert answer.headers["location"].startswith(f"https://{ROBOT}")
    assert answer.headers["location"].endswith("/api/livez")


def test_the_robots_own_name_is_served_and_any_other_name_is_refused(proxied: Proxied) -> None:
    """Issue 31: with ROBOT_HOSTNAME=robot-7.lan the brain answered 400 untrusted_host."""
    with https_client(proxied) as client:
        assert client.get("/api/livez").status_code == 200
    direct = httpx.get(f"{proxied.brain}/api/livez", headers={"Host": "evil.example"}, timeout=10)
    assert direct.status_code == 400
    assert direct.json()["reason"] == "untrusted_host"


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
    # the brain believes X-Forwarded-Proto from Caddy on its proxy socket only
    assert "secure" in proxied_login.headers["set-cookie"].lower()
    assert "secure" not in direct.headers["set-cookie"].lower()
    spoofed = httpx.post(
        f"{proxied.brain}/api/auth/login",
        json=credentials,
        headers={"X-Forwarded-Proto": "https", "X-Forwarded-For": "10.1.2.3"},
        timeout=10,
    )
    assert spoofed.status_code == 200, spoofed.text
    assert "secure" not in spoofed.headers["set-cookie"].lower()  # not from a local client


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
            headers={"Cookie": cookie, "Host": proxied.host},
            wait_timeout=10,
        )
        try:
            return str(sio.transport())
        finally:
            await sio.disconnect()

    # aiohttp (the client's transport) drops a TLS socket without waiting for its close
    # (aio-libs/aiohttp#1925); now and then one is left for the garbage collector, and its
    # ResourceWarning failed whichever test ran next. Collect it here, where it is known.
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ResourceWarning)
        assert asyncio.run(connect()) == "websocket"
        gc.collect()


def test_socketio_without_a_session_is_refused_through_the_proxy(proxied: Proxied) -> None:
    handshake = "/socket.io/?EIO=4&transport=polling"
    with https_client(proxied) as client:
        refused = client.get(handshake)
        client.post("/api/auth/login", json={"username": "operator", "password": PASSWORD})
        accepted = client.get(handshake)
    assert refused.status_code == 401, refused.text
    assert accepted.status_code == 200, accepted.text
