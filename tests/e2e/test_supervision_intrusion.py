"""Issue 35 through the whole chain, on one start of the local stack (robot-sim honouring the
supervisor lock, memory, navigation, the brain on the dev preset), with an intruder on the
robot's ROS domain (``robot_stack_testing.navigation.intruder``: a plain rclpy process, no
credential):

- latched, ``false`` published on ``/robot/supervisor_lock`` at 200 Hz and a NavigateToPose goal
  sent straight to robot-sim: the robot does not drive (robot-sim's ``/amcl_pose``), the goal
  ends CANCELED, ``/api/safety`` stays latched and names the alarm; once the intruder left and
  the alarms cleared, Clear stop moves nothing;
- a fake ``/amcl_pose`` publisher: the brain latches and ``/api/safety`` names the alarm.

Server-level detail (the operator's credential refused, another holder) is in
packages/robot_mcp_navigation/tests/integration/test_nav_supervision_intrusion.py; how fast, in
benchmarks/supervision_intrusion.py.
"""

from __future__ import annotations

import json
import math
import sys
from collections.abc import AsyncIterator, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import httpx
import pytest

from robot_stack_testing import LaunchedProcess, ProcessLauncher, async_wait_until, wait_until
from robot_stack_testing.mission_driver import fresh_secret, stack_env
from robot_stack_testing.pose_watch import AmclWatch
from robot_stack_testing.stack import LocalStack, free_port_overrides, local_stack, stack_defaults

pytestmark = [pytest.mark.slow, pytest.mark.ros, pytest.mark.timeout(300)]

ROOT = Path(__file__).resolve().parents[2]
STACK_FILE = ROOT / "deploy" / "local-stack.yaml"
KITCHEN = "9.0,-3.0"
STILL_M = 2.0
"""How far the robot may roll while a goal sent straight to the base is being cancelled (rolled
p50 0.02 m / p99 1.5 m on a loaded host in benchmarks/supervision_intrusion.py; the goal is
9.5 m away and the review's run drove there); after the cancel it must not move at all."""
STILL = 0.01


@dataclass
class Stack:
    services: LocalStack
    brain: str
    watch: AmclWatch


@pytest.fixture(scope="module")
def stack(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Stack]:
    placeholders = {
        **stack_defaults(STACK_FILE),
        **free_port_overrides(STACK_FILE),
        "nav_time_scale": "1",
        "brain_config_overrides": "",  # the dev preset as shipped
        "reconnect_interval_s": "1",
    }
    var = tmp_path_factory.mktemp("intrusion") / "var"
    watch = AmclWatch()
    try:
        with local_stack(
            ROOT,
            var,
            stack_env(fresh_secret()),
            overrides=placeholders,
            only={"robot_sim", "memory", "navigation", "brain"},
        ) as services:
            yield Stack(services, f"http://127.0.0.1:{placeholders['brain_port']}", watch)
    finally:
        watch.close()


@pytest.fixture
async def http(stack: Stack) -> AsyncIterator[httpx.AsyncClient]:
    async with httpx.AsyncClient(base_url=stack.brain, timeout=30.0) as client:
        yield client


@pytest.fixture
def launcher(tmp_path: Path) -> Iterator[ProcessLauncher]:
    started = ProcessLauncher(tmp_path)
    try:
        yield started
    finally:
        started.stop_all()


async def supervised(http: httpx.AsyncClient) -> bool:
    data = (await http.get("/api/readyz")).json()["data"]
    lease = (data["supervision"] or {}).get("servers", {}).get("navigation", {})
    return bool(data["mcp_servers"].get("navigation") == "connected" and lease.get("fresh"))


async def safety(http: httpx.AsyncClient) -> dict[str, Any]:
    state: dict[str, Any] = (await http.get("/api/safety")).json()
    return state


async def alarm_codes(http: httpx.AsyncClient) -> set[str]:
    return {a["code"] for a in (await safety(http)).get("alarms", [])}


def start_intruder(launcher: ProcessLauncher, *args: str) -> LaunchedProcess:
    process = launcher.start(
        "intruder", [sys.executable, "-m", "robot_stack_testing.navigation.intruder", *args]
    )
    wait_until(lambda: "intruder_ready" in process.log(), 60, "the intruder")
    return process


def events(process: LaunchedProcess, name: str) -> list[dict[str, Any]]:
    lines = [line for line in process.log().splitlines() if line.startswith("{")]
    return [e for e in (json.loads(line) for line in lines) if e.get("event") == name]


def furthest_since(watch: AmclWatch, origin: tuple[float, float], stamp: float) -> float:
    return max(
        (math.dist(origin, (s.x, s.y)) for s in watch.samples() if s.stamp >= stamp), default=0.0
    )


async def clear_when_quiet(http: httpx.AsyncClient) -> None:
    """The alarms gone (the brain's latched renewals acknowledged them), then Clear stop."""
    await async_wait_until(lambda: _no_alarms(http), 90, "the alarms cleared", 0.2)
    cleared = await http.post("/api/safety/clear", json={"reason": "test: intruder removed"})
    assert cleared.status_code == 200, cleared.text


async def _no_alarms(http: httpx.AsyncClient) -> bool:
    return not await alarm_codes(http)


async def test_a_spoofed_lock_and_a_direct_goal_while_latched_move_nothing_and_are_named(
    stack: Stack, http: httpx.AsyncClient, launcher: ProcessLauncher
) -> None:
    await async_wait_until(lambda: supervised(http), 90, "navigation supervised", 0.2)
    if not (await safety(http))["latched"]:
        stopped = await http.post("/api/safety/stop", json={"reason": "test: latched first"})
        assert stopped.status_code == 200, stopped.text
    await async_wait_until(stack.watch.latest, 30, "a pose", 0.1)
    latest = stack.watch.latest()
    assert latest is not None
    origin, since = (latest.x, latest.y), latest.stamp

    intruder = start_intruder(
        launcher, "--lock-topic", "/robot/supervisor_lock", "--lock-hz", "200", "--goal", KITCHEN
    )
    await async_wait_until(lambda: events(intruder, "goal_ended"), 60, "the goal's end", 0.1)
    await async_wait_until(
        lambda: _has(http, "LOCK_TOPIC_SHARED"), 30, "the alarm in /api/safety", 0.2
    )
    state = await safety(http)

    assert events(intruder, "goal_ended")[0]["status"] == "canceled", intruder.log()
    assert furthest_since(stack.watch, origin, since) < STILL_M
    assert state["latched"] is True
    assert any(a["server"] == "navigation" for a in state["alarms"]), state
    assert state["reason"], state  # the latch says why, in words
    await async_wait_until(stack.watch.halted_at, 30, "the robot still", 0.1)
    rest = stack.watch.latest()
    assert rest is not None

    launcher.stop(intruder)
    await clear_when_quiet(http)
    cleared = stack.watch.latest()
    assert cleared is not None

    def forty_more_poses() -> bool:
        return sum(1 for s in stack.watch.samples() if s.stamp > cleared.stamp) >= 40

    await async_wait_until(forty_more_poses, 30, "40 poses after the clear", 0.1)
    assert furthest_since(stack.watch, (rest.x, rest.y), rest.stamp) < STILL  # nothing ran on clear
    assert not stack.watch.moving()


async def _has(http: httpx.AsyncClient, code: str) -> bool:
    return code in await alarm_codes(http)


async def test_a_fake_pose_publisher_latches_the_brain_and_the_banner_names_it(
    stack: Stack, http: httpx.AsyncClient, launcher: ProcessLauncher
) -> None:
    await async_wait_until(lambda: supervised(http), 90, "navigation supervised", 0.2)
    if (await safety(http))["latched"]:
        await clear_when_quiet(http)

    start_intruder(launcher, "--pose", "20,20")
    await async_wait_until(lambda: _has(http, "POSE_TOPIC_SHARED"), 30, "the alarm", 0.2)
    state = await safety(http)

    assert state["latched"] is True
    [alarm] = [a for a in state["alarms"] if a["code"] == "POSE_TOPIC_SHARED"]
    assert "/amcl_pose" in alarm["detail"]
    assert "/intruder" in alarm["detail"]
