"""deploy/smoke.sh (RUNBOOK step 5 + 6) against the whole local stack on free ports: every
service a real OS process from deploy/local-stack.yaml, the brain on its dev preset.

The recorded (replay) planner plays one mission per brain process, so the brain is restarted
between the taught mission and the repeat; on a robot the steps run back to back. The memory
and navigation servers keep running, so the taught process survives the restart. The brain
comes back with operator login on, so the second part also runs smoke.sh's login checks and
its Socket.IO connect with a session cookie.

With the software stop latched at the end, another local process tries to drive through the
navigation server without and with a wrong credential (issue 27): 401, and robot-sim's
``/amcl_pose`` does not move."""

from __future__ import annotations

import asyncio
import dataclasses
import math
import os
import re
import secrets
import subprocess
import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import httpx
import pytest

from robot_stack_testing import fresh_token, wait_until
from robot_stack_testing.mission_driver import RunningStack, call_mcp, mailroom_stack
from robot_stack_testing.stack import free_port_overrides
from robot_voice_chat.api.auth import hash_password

pytestmark = [pytest.mark.ros, pytest.mark.slow]

ROOT = Path(__file__).resolve().parents[2]
STACK_FILE = ROOT / "deploy" / "local-stack.yaml"
SMOKE = ROOT / "deploy" / "smoke.sh"
PASSWORD = "smoke-test operator password"


@pytest.fixture
def stack(tmp_path: Path) -> Iterator[RunningStack]:
    # a slow enough base that "stop" lands mid-drive
    overrides = {**free_port_overrides(STACK_FILE), "nav_time_scale": "4"}
    with mailroom_stack(ROOT, tmp_path / "var", overrides) as running:
        yield running


def run_smoke(
    stack: RunningStack, tmp_path: Path, steps: str, **extra: str
) -> subprocess.CompletedProcess[str]:
    ports = stack.placeholders
    env = {
        **os.environ,
        "SMOKE_BRAIN_PORT": ports["brain_port"],
        "SMOKE_NAVIGATION_PORT": ports["navigation_port"],
        "SMOKE_MEMORY_PORT": ports["memory_port"],
        "SMOKE_SKILL_CONTROL_PORT": ports["skill_control_port"],
        "SMOKE_PERCEPTION_PORT": ports["perception_port"],
        "SMOKE_EPISODIC_PORT": ports["episodic_port"],
        "SMOKE_VISION_PORT": ports["vision_port"],
        "SMOKE_LOG_CMD": f"cat {tmp_path}/var/brain-*.log",
        "SMOKE_PYTHON": sys.executable,
        "SMOKE_STATE": str(tmp_path / "smoke-state"),
        "SMOKE_CREDENTIALS": str(stack.write_operator_credentials(tmp_path / "operator.env")),
        "SMOKE_TIMEOUT": "90",
        **extra,
    }
    return subprocess.run(
        ["bash", str(SMOKE), "--steps", steps],
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
    )


def smoke(stack: RunningStack, tmp_path: Path, steps: str, **extra: str) -> str:
    result = run_smoke(stack, tmp_path, steps, **extra)
    output = result.stdout + result.stderr
    assert result.returncode == 0, output
    assert f"smoke: all passed ({steps})" in output
    return output


@pytest.mark.timeout(900)
def test_smoke_script_passes_on_the_local_stack(stack: RunningStack, tmp_path: Path) -> None:
    first = smoke(stack, tmp_path, "http,mission")
    assert "ok   navigation MCP server" in first
    assert "ok   mission_finished: succeeded" in first
    assert "ok   process saved: fetch-package-from-mailroom" in first
    mission_id = re.search(r"ok   mission (m-[0-9a-f]+) started", first)
    assert mission_id, first
    # one correlation id per mission: in the log of every process the mission went through
    # (the brain and each MCP server; the vision node is reached over ROS, not MCP)
    for process in ("brain", "memory", "navigation", "skill_control", "perception"):
        logs = " ".join(p.read_text() for p in (tmp_path / "var").glob(f"{process}-*.log"))
        assert f'"mission_id": "{mission_id[1]}"' in logs, process
    # ... and in the signed events the servers posted for it
    snapshot = httpx.get(stack.url("brain", f"/api/agent/missions/{mission_id[1]}"), timeout=10)
    events = [e for e in snapshot.json()["events"] if e["kind"] == "task_event"]
    assert events
    assert {e["payload"].get("mission_id") for e in events} == {mission_id[1]}
    # the stack's state after a whole mission is its user's alone (issue 35: outboxes,
    # memory.sqlite3 and logs were 0644, the episodic directory 0755)
    state = [tmp_path / "var", *(tmp_path / "var").rglob("*")]
    assert any(p.name == "memory.sqlite3" for p in state)
    assert any(p.name == "episodic" for p in state)
    open_to_others = [
        f"{oct(p.stat().st_mode & 0o777)} {p}" for p in state if p.stat().st_mode & 0o077
    ]
    assert not open_to_others, open_to_others[:10]

    # the repeat runs against the brain with operator login on, as on a robot
    brain = stack.services.specs["brain"]
    stack.services.specs["brain"] = dataclasses.replace(
        brain,
        argv=[*brain.argv, "auth.enabled=true"],
        env={
            **brain.env,
            "ADMIN_PASSWORD_HASH": hash_password(PASSWORD),
            "ADMIN_SECRET_KEY": secrets.token_urlsafe(32),
        },
    )
    stack.services.restart("brain")
    again = smoke(stack, tmp_path, "http,repeat", SMOKE_PASSWORD=PASSWORD)
    assert "ok   auth: /api/agent/missions without a session → 401" in again
    assert "ok   auth: login → session cookie → /api/auth/me" in again
    assert "ok   logged in as operator" in again
    assert "the taught process injected" in again
    assert "ok   mission paused after 'stop'" in again
    assert "ok   robot asks: continue or abort?" in again
    # "stop" latched the software stop; the smoke says so and never clears it itself ...
    assert "note the software stop is now latched" in again
    # ... so the next run refuses before any step, saying who latched it and how to clear it
    refused = run_smoke(stack, tmp_path, "http", SMOKE_PASSWORD=PASSWORD)
    assert refused.returncode == 1, refused.stdout + refused.stderr
    assert "FAIL the software stop is latched (since " in refused.stdout
    assert "(Clear stop)" in refused.stdout
    assert "--- http" not in refused.stdout
    assert "200 with its own" in first
    # the stop is latched: another local process tries to drive the robot, without the
    # navigation server's credential and with a wrong one — refused, and the robot stays
    navigation = stack.url("navigation", "/sse")
    with amcl_poses() as poses:
        wait_until(lambda: poses, 30, "robot-sim's /amcl_pose")
        for token in (None, fresh_token()):
            with pytest.raises(BaseException) as refused_call:
                asyncio.run(
                    call_mcp(navigation, "navigate_to", {"location": "reception"}, token=token)
                )
            assert "401" in str(leaves(refused_call.value))
        seen = len(poses)
        wait_until(lambda: len(poses) >= seen + 40, 30, "two more seconds of /amcl_pose")
    first_pose = poses[0]
    assert all(math.dist(first_pose, pose) < 0.01 for pose in poses), poses[-1]
    nav_log = " ".join(p.read_text() for p in (tmp_path / "var").glob("navigation-*.log"))
    assert '"event": "mcp_auth_rejected"' in nav_log
    assert stack.credentials["navigation"] not in nav_log


def leaves(error: BaseException) -> list[str]:
    if isinstance(error, BaseExceptionGroup):
        return [text for inner in error.exceptions for text in leaves(inner)]
    return [str(error)]


@contextmanager
def amcl_poses() -> Iterator[list[tuple[float, float]]]:
    """robot-sim's pose as a robot publishes it (x, y of each /amcl_pose message)."""
    from geometry_msgs.msg import PoseWithCovarianceStamped

    from robot_ros_bridge import RosBridge
    from robot_sim.node import AMCL_QOS

    poses: list[tuple[float, float]] = []
    lock = threading.Lock()

    def heard(message: Any) -> None:
        with lock:
            position = message.pose.pose.position
            poses.append((position.x, position.y))

    with RosBridge("smoke_test_amcl_listener") as bridge:
        bridge.create_subscription(PoseWithCovarianceStamped, "/amcl_pose", heard, AMCL_QOS)
        yield poses


@pytest.mark.timeout(300)
def test_smoke_script_fails_when_a_server_is_down(stack: RunningStack, tmp_path: Path) -> None:
    stack.services.launcher.stop(stack.services["navigation"])
    ports = stack.placeholders
    result = subprocess.run(
        ["bash", str(SMOKE), "--steps", "http"],
        env={
            **os.environ,
            "SMOKE_BRAIN_PORT": ports["brain_port"],
            "SMOKE_NAVIGATION_PORT": ports["navigation_port"],
            "SMOKE_LOG_CMD": "true",
        },
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert result.returncode == 1
    assert f"FAIL navigation MCP server: GET :{ports['navigation_port']}/sse" in result.stdout
