"""The proxy socket: where forwarded headers are believed (issue 31)."""

from __future__ import annotations

import shutil
import socket
import stat
import tempfile
from collections.abc import Iterator
from pathlib import Path

import pytest
import structlog
import structlog.testing

from robot_voice_chat.api.forwarded import SOCKET_MODE, unix_listener
from robot_voice_chat.main import main


@pytest.fixture
def short_dir() -> Iterator[Path]:
    path = Path(tempfile.mkdtemp(prefix="rvc-", dir="/tmp"))  # sun_path is 108 bytes
    yield path
    shutil.rmtree(path, ignore_errors=True)


def test_the_proxy_socket_is_for_the_brains_user_and_group_and_replaces_a_stale_one(
    short_dir: Path,
) -> None:
    path = short_dir / "proxy.sock"
    first = unix_listener(path)
    first.close()  # an earlier process life left its socket file behind
    second = unix_listener(path)
    try:
        assert stat.S_ISSOCK(path.stat().st_mode)
        assert stat.S_IMODE(path.stat().st_mode) == SOCKET_MODE
        with socket.socket(socket.AF_UNIX) as client:
            client.connect(str(path))
    finally:
        second.close()


def test_a_proxy_socket_path_that_is_not_a_socket_refuses_the_start(
    short_dir: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr("robot_voice_chat.main.configure_logging", lambda *a: None)
    monkeypatch.setenv("RVC_DATA_DIR", str(short_dir / "data"))
    precious = short_dir / "notes.txt"
    precious.write_text("keep me", encoding="utf-8")
    with structlog.testing.capture_logs() as logs:
        assert main(["--port", "0", "--proxy-socket", str(precious)]) == 2
    assert precious.read_text(encoding="utf-8") == "keep me"
    refused = [log for log in logs if log["event"] == "startup_refused"]
    assert "is not a socket" in refused[0]["error"]
