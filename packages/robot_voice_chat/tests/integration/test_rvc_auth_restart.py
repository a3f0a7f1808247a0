"""Operator sessions across a real restart of the brain (kill -9, start again): a logout and a
password change stay in force; a session that was neither still works."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest

from robot_stack_testing import wait_until
from robot_stack_testing.ports import free_tcp_port
from robot_voice_chat.api.auth import hash_password

PASSWORD = "restart test password"


@pytest.fixture
def brains() -> Iterator[list[subprocess.Popen[bytes]]]:
    started: list[subprocess.Popen[bytes]] = []
    yield started
    for process in started:
        if process.poll() is None:
            process.kill()
            process.wait(10)


def start_brain(
    tmp_path: Path, port: int, password_hash: str, started: list[subprocess.Popen[bytes]]
) -> str:
    closed = f"http://127.0.0.1:{free_tcp_port()}/sse"
    env = {k: v for k, v in os.environ.items() if not k.startswith(("RVC_", "ADMIN_"))}
    env.update(
        RVC_DEPLOYMENT="test",
        RVC_CONFIG_OVERRIDES="auth.enabled=true",
        RVC_DATA_DIR=str(tmp_path / "data"),  # where the revocation list lives
        RVC_NAVIGATION_URL=closed,
        RVC_MEMORY_URL=closed,
        RVC_SKILL_CONTROL_URL=closed,
        RVC_PERCEPTION_URL=closed,
        ADMIN_USERNAME="ada",
        ADMIN_PASSWORD_HASH=password_hash,
        ADMIN_SECRET_KEY="a-session-signing-key-that-is-long-enough",
    )
    process = subprocess.Popen(
        [sys.executable, "-m", "robot_voice_chat", "--port", str(port)],
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    started.append(process)
    url = f"http://127.0.0.1:{port}"

    def serving() -> bool:
        assert process.poll() is None, "the brain exited"
        try:
            return httpx.get(f"{url}/api/livez", timeout=2).status_code == 200
        except httpx.HTTPError:
            return False

    wait_until(serving, 60, "the brain serving")
    return url


def kill_9(process: subprocess.Popen[bytes]) -> None:
    process.send_signal(signal.SIGKILL)
    process.wait(10)


def session(url: str, password: str = PASSWORD) -> str:
    response = httpx.post(f"{url}/api/auth/login", json={"username": "ada", "password": password})
    assert response.status_code == 200, response.text
    return response.cookies["rvc_session"]


def status_with(url: str, token: str) -> int:
    return httpx.get(f"{url}/api/agent/missions", cookies={"rvc_session": token}).status_code


def test_a_logout_and_a_password_change_survive_a_restart(
    tmp_path: Path, brains: list[subprocess.Popen[bytes]]
) -> None:
    port = free_tcp_port()
    first_hash = hash_password(PASSWORD)
    url = start_brain(tmp_path, port, first_hash, brains)
    logged_out, kept = session(url), session(url)
    logout = httpx.post(f"{url}/api/auth/logout", cookies={"rvc_session": logged_out})
    assert logout.status_code == 200
    assert (status_with(url, logged_out), status_with(url, kept)) == (401, 200)

    kill_9(brains[-1])
    url = start_brain(tmp_path, port, first_hash, brains)
    assert (status_with(url, logged_out), status_with(url, kept)) == (401, 200)

    kill_9(brains[-1])  # the operator changes the password
    url = start_brain(tmp_path, port, hash_password("a brand new password"), brains)
    assert status_with(url, kept) == 401
    assert status_with(url, session(url, "a brand new password")) == 200
