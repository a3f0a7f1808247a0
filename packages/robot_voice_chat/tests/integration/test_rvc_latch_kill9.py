"""The latched software stop survives a kill -9 of a real brain process and a restart."""

from __future__ import annotations

import json
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


def brain_env(tmp_path: Path) -> dict[str, str]:
    closed = f"http://127.0.0.1:{free_tcp_port()}/sse"  # no servers: the brain keeps retrying
    env = {k: v for k, v in os.environ.items() if not k.startswith("RVC_")}
    env.update(
        RVC_DEPLOYMENT="dev",
        RVC_DATA_DIR=str(tmp_path / "data"),
        RVC_NAVIGATION_URL=closed,
        RVC_MEMORY_URL=closed,
        RVC_SKILL_CONTROL_URL=closed,
        RVC_PERCEPTION_URL=closed,
    )
    return env


class Brain:
    def __init__(self, tmp_path: Path) -> None:
        self.env = brain_env(tmp_path)
        self.port = free_tcp_port()
        self.url = f"http://127.0.0.1:{self.port}"
        self.process: subprocess.Popen[bytes] | None = None

    def start(self) -> None:
        self.process = subprocess.Popen(
            [sys.executable, "-m", "robot_voice_chat", "--port", str(self.port)],
            env=self.env,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        process = self.process

        def answers() -> bool:
            assert process.poll() is None, "the brain exited"
            try:
                return httpx.get(f"{self.url}/api/livez", timeout=2).status_code == 200
            except httpx.HTTPError:
                return False

        wait_until(answers, 60, "brain serving /api/livez")

    def kill9(self) -> None:
        assert self.process is not None
        self.process.send_signal(signal.SIGKILL)
        self.process.wait(10)

    def stop(self) -> None:
        if self.process is not None and self.process.poll() is None:
            self.process.terminate()
            try:
                self.process.wait(10)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait(5)


@pytest.fixture
def brain(tmp_path: Path) -> Iterator[Brain]:
    b = Brain(tmp_path)
    try:
        yield b
    finally:
        b.stop()


def test_the_latch_survives_kill_9_and_a_restart(brain: Brain) -> None:
    brain.start()
    stopped = httpx.post(f"{brain.url}/api/safety/stop", json={"reason": "person in the way"})
    assert stopped.status_code == 200
    assert stopped.json()["latched"] is True
    brain.kill9()

    brain.start()
    state = httpx.get(f"{brain.url}/api/safety").json()
    assert state["latched"] is True
    assert state["reason"] == "person in the way"
    ready = httpx.get(f"{brain.url}/api/readyz").json()
    assert ready["data"]["safety"]["latched"] is True
    # a mission this brain could start without servers (no drive: the chat refuses a drive
    # while navigation is down before any mission is tried) is refused by the latch
    reply = httpx.post(f"{brain.url}/api/chat", json={"text": "what do you see?"}, timeout=30)
    assert "software stop is latched" in reply.json()["reply"]


def test_a_corrupt_latch_file_reads_latched_in_a_real_brain(brain: Brain, tmp_path: Path) -> None:
    brain.start()
    httpx.post(f"{brain.url}/api/safety/stop", json={"reason": "stop"})
    brain.kill9()
    (tmp_path / "data" / "safety" / "latch.json").write_bytes(b"\x00\x00garbage")

    brain.start()
    state = httpx.get(f"{brain.url}/api/safety").json()
    assert state["latched"] is True
    assert "corrupt" in state["reason"]


def test_clear_stop_records_who_and_why_and_survives_a_restart(
    brain: Brain, tmp_path: Path
) -> None:
    brain.start()
    httpx.post(f"{brain.url}/api/safety/stop", json={"reason": "stop"})
    too_short = httpx.post(f"{brain.url}/api/safety/clear", json={"reason": ""})
    assert too_short.status_code == 422
    cleared = httpx.post(f"{brain.url}/api/safety/clear", json={"reason": "corridor checked"})
    assert cleared.status_code == 200
    assert cleared.json()["latched"] is False
    again = httpx.post(f"{brain.url}/api/safety/clear", json={"reason": "corridor checked"})
    assert again.status_code == 409
    brain.kill9()

    brain.start()
    assert httpx.get(f"{brain.url}/api/safety").json()["latched"] is False
    journal = (tmp_path / "data" / "safety" / "latch.journal").read_text().splitlines()
    clear = json.loads(journal[-1])
    assert clear["event"] == "clear"
    assert clear["reason"] == "corridor checked"
    assert clear["by"] == "local operator (no login)"
