"""Socket.IO accepts same-origin pages and the configured allow-list only (issue 13 item 17)."""

from __future__ import annotations

from pathlib import Path

import httpx
import pytest
from pydantic import ValidationError

from robot_voice_chat.api.app import create_asgi_app
from robot_voice_chat.composition import bootstrap, compose_config
from robot_voice_chat.settings import ApiConfig

HANDSHAKE = "/socket.io/?EIO=4&transport=polling"


def served_app(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, overrides: list[str]) -> object:
    monkeypatch.setenv("RVC_TRACE_DIR", str(tmp_path))
    hosts = "api.trusted_hosts=[brain.local,localhost]"  # the name this test serves under
    return create_asgi_app(bootstrap(compose_config("dev", [hosts, *overrides])))


async def handshake(app: object, origin: str | None) -> httpx.Response:
    headers = {"Origin": origin} if origin else {}
    transport = httpx.ASGITransport(app)  # type: ignore[arg-type]
    async with httpx.AsyncClient(transport=transport, base_url="http://brain.local:8000") as c:
        return await c.get(HANDSHAKE, headers=headers)


async def test_a_foreign_page_cannot_open_a_socket_but_the_served_ui_can(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    app = served_app(tmp_path, monkeypatch, [])
    foreign = await handshake(app, "http://evil.example")
    assert foreign.status_code == 400
    assert "not an accepted origin" in foreign.text
    same = await handshake(app, "http://brain.local:8000")
    assert same.status_code == 200
    assert same.headers["access-control-allow-origin"] == "http://brain.local:8000"
    # a TLS proxy in front keeps the Host: same origin whatever the scheme
    assert (await handshake(app, "https://brain.local:8000")).status_code == 200
    # a non-browser client sends no Origin and is not subject to CORS
    assert (await handshake(app, None)).status_code == 200


async def test_an_origin_in_the_config_allow_list_may_connect(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    app = served_app(tmp_path, monkeypatch, ["api.cors_origins=[http://localhost:5173]"])
    assert (await handshake(app, "http://localhost:5173")).status_code == 200
    assert (await handshake(app, "http://localhost:5174")).status_code == 400


@pytest.mark.parametrize("entry", ["*", "http://*.example.org", "https://ui.example/path", "ui"])
def test_allow_list_entries_must_be_exact_origins(entry: str) -> None:
    with pytest.raises(ValidationError, match="exact origin"):
        ApiConfig(cors_origins=[entry])
