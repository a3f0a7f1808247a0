"""Supervision with real ``kill -9`` mid-drive (issue 27), on one start of the local stack
(robot-sim honouring the supervisor lock, memory, navigation, the brain on the dev preset):

- navigation killed → robot-sim's ``/amcl_pose`` stops changing (its lock fell silent), the
  person is told, and "stop" then says what is true, never "Stopped.";
- the restarted navigation server, latched by the brain's lease, refuses a direct
  ``navigate_to`` from another local client and nothing moves;
- robot-sim frozen mid-drive (SIGSTOP, as a host starved of CPU freezes it) until navigation
  counts the base as lost, then let go → the brain waits for a fresh pose, re-issues the drive
  once, says so in plain words, and the robot arrives (robot-sim's pose);
- robot-sim killed → the drive ends BASE_UNAVAILABLE (not by the drive timeout), the pose is
  stale, and the base's return at the dock is reported as a relocation, not a silent jump.

The brain's own kill -9 is in test_brain_crash_recovery.py (same chain, one stack start each).
Halts are dated by the robot's own pose messages (AmclWatch), read from ROS. The issue's
bounds are speed goals, measured in benchmarks/supervision_halt.py (1 s for the halts is met
there with p99 0.86 s); here the deadlines only tell a halted robot from one that drives on.
"""

from __future__ import annotations

import os
import signal
import time
from collections.abc import AsyncIterator, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import httpx
import pytest

from robot_stack_testing import async_wait_until
from robot_stack_testing.mission_driver import call_mcp, fresh_secret, stack_env
from robot_stack_testing.pose_watch import AmclWatch
from robot_stack_testing.stack import LocalStack, free_port_overrides, local_stack, stack_defaults

pytestmark = [pytest.mark.slow, pytest.mark.ros, pytest.mark.timeout(300)]

ROOT = Path(__file__).resolve().parents[2]
STACK_FILE = ROOT / "deploy" / "local-stack.yaml"
# Deadlines that tell "halted / reported" from "drove on / waited" on a loaded shared host, not
# speed goals: the bounds (halted ≤ 1 s, BASE_UNAVAILABLE ≤ 5 s) are measured in
# benchmarks/supervision_halt.py. Without supervision the robot drives on after these kills until
# it arrives (12 s to the kitchen at time scale 1) and a lost base is reported by the drive
# timeout (3 × ETA + 30 s ≈ 65 s) — far beyond these.
HALTED_WITHIN_S = 3.0
TOLD_WITHIN_S = 10.0
LOST_BASE_WITHIN_S = 15.0


@dataclass
class Stack:
    services: LocalStack
    brain: str
    navigation: str
    watch: AmclWatch

    async def nav(self, tool: str, arguments: dict[str, Any]) -> Any:
        """navigation's tool as another local client would call it: an operator's tool with
        its own credential (not the brain)."""
        token = self.services.operator_credentials["navigation"]
        return await call_mcp(self.navigation, tool, arguments, token=token)


@pytest.fixture(scope="module")
def stack(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Stack]:
    placeholders = {
        **stack_defaults(STACK_FILE),
        **free_port_overrides(STACK_FILE),
        "nav_time_scale": "1",  # drives long enough to be killed in
        "brain_config_overrides": "",  # the dev preset as shipped: rules, no keys
        "reconnect_interval_s": "1",
    }
    var = tmp_path_factory.mktemp("supervision") / "var"
    watch = AmclWatch()
    try:
        with local_stack(
            ROOT,
            var,
            stack_env(fresh_secret()),
            overrides=placeholders,
            only={"robot_sim", "memory", "navigation", "brain"},
        ) as services:
            yield Stack(
                services,
                f"http://127.0.0.1:{placeholders['brain_port']}",
                f"http://127.0.0.1:{placeholders['navigation_port']}/sse",
                watch,
            )
    finally:
        watch.close()


@pytest.fixture
async def http(stack: Stack) -> AsyncIterator[httpx.AsyncClient]:
    async with httpx.AsyncClient(base_url=stack.brain, timeout=30.0) as client:
        yield client


def kill9(stack: Stack, name: str) -> float:
    process = stack.services[name]
    os.kill(process.pid, signal.SIGKILL)
    killed = time.time()
    process.popen.wait(timeout=10)
    return killed


async def supervised(http: httpx.AsyncClient) -> bool:
    data = (await http.get("/api/readyz")).json()["data"]
    lease = (data["supervision"] or {}).get("servers", {}).get("navigation", {})
    return bool(data["mcp_servers"].get("navigation") == "connected" and lease.get("fresh"))


async def mission(http: httpx.AsyncClient, mission_id: str) -> dict[str, Any]:
    data: dict[str, Any] = (await http.get(f"/api/agent/missions/{mission_id}")).json()
    return data


async def said(http: httpx.AsyncClient, mission_id: str) -> str:
    log = (await mission(http, mission_id))["log"]
    return " ".join(line["text"] for line in log if line["kind"] == "say")


async def said_at(http: httpx.AsyncClient, mission_id: str, words: str) -> float | None:
    """When the mission first said ``words`` (its log line's time), or None."""
    log = (await mission(http, mission_id))["log"]
    return next(
        (line["ts"] for line in log if line["kind"] == "say" and words in line["text"]), None
    )


async def drive(stack: Stack, http: httpx.AsyncClient, place: str) -> str:
    """A mission driving to ``place`` (the stop clear first), once the robot moves."""
    await async_wait_until(lambda: supervised(http), 60, "navigation supervised", 0.2)
    if (await http.get("/api/safety")).json()["latched"]:
        cleared = await http.post("/api/safety/clear", json={"reason": "test: corridor clear"})
        assert cleared.status_code == 200, cleared.text
    started = (await http.post("/api/chat", json={"text": f"go to the {place}"})).json()
    assert started["route"] == "mission_started", started
    await async_wait_until(stack.watch.moving, 60, "the robot driving", 0.1)
    return str(started["mission_id"])


def away_from_dock(watch: AmclWatch, metres: float = 1.0) -> Any:
    """The robot is ``metres`` from the dock (0, 0): its return there is a jump worth saying."""

    def far() -> bool:
        latest = watch.latest()
        return latest is not None and (latest.x**2 + latest.y**2) ** 0.5 >= metres

    return far


async def end_mission(http: httpx.AsyncClient) -> None:
    async def idle() -> bool:
        if (await http.get("/api/agent/missions")).json()["active"] is None:
            return True
        await http.post("/api/chat", json={"text": "abort"})
        return False

    await async_wait_until(idle, 60, "no mission running", 0.5)


async def test_navigation_killed_mid_drive_halts_the_robot_and_stop_says_what_is_true(
    stack: Stack, http: httpx.AsyncClient
) -> None:
    mission_id = await drive(stack, http, "meeting room")

    killed = kill9(stack, "navigation")

    await async_wait_until(lambda: stack.watch.halted_at() is not None, 20, "the halt", 0.1)
    halted = stack.watch.halted_at()
    assert halted is not None
    assert halted - killed <= HALTED_WITHIN_S, f"halted {halted - killed:.2f} s after the kill"

    lost = "lost contact with my navigation"
    told = await async_wait_until(lambda: said_at(http, mission_id, lost), 30, "told", 0.2)
    assert told is not None
    assert told - killed <= TOLD_WITHIN_S, f"told {told - killed:.2f} s after the kill"
    assert "holds itself stopped" in await said(http, mission_id)
    assert "Say stop to halt me" not in await said(http, mission_id)

    reply = (await http.post("/api/chat", json={"text": "stop"})).json()["reply"]
    assert not reply.startswith("Stopped."), reply
    assert "could not reach my navigation" in reply
    assert "lapsed at" in reply
    assert stack.watch.halted_at() == halted  # words = world: it has not moved since

    stack.services.start(stack.services.specs["navigation"])
    await async_wait_until(lambda: supervised(http), 60, "navigation back, supervised", 0.2)
    refused = await stack.nav("navigate_to", {"location": "kitchen"})
    assert refused["_error"]["error"] == "SAFETY_STOP_LATCHED", refused
    assert stack.watch.halted_at() == halted  # another local client moved nothing
    await end_mission(http)


async def test_robot_sim_frozen_for_a_moment_mid_drive_and_the_robot_still_arrives(
    stack: Stack, http: httpx.AsyncClient
) -> None:
    mission_id = await drive(stack, http, "kitchen")
    await async_wait_until(away_from_dock(stack.watch), 30, "the robot 1 m from the dock", 0.1)
    robot_sim = stack.services["robot_sim"].pid

    async def base_lost_shown() -> bool:
        steps = (await mission(http, mission_id))["steps"]
        return any("contact with the base lost" in (s.get("detail") or "") for s in steps)

    os.kill(robot_sim, signal.SIGSTOP)
    try:  # navigation's feedback timeout (3 s) runs out while robot-sim is frozen
        await async_wait_until(base_lost_shown, 30, "the brain waiting for its base", 0.1)
    finally:
        os.kill(robot_sim, signal.SIGCONT)

    async def finished() -> dict[str, Any] | None:
        data = await mission(http, mission_id)
        return data if data["state"] in ("succeeded", "failed", "aborted") else None

    ended = await async_wait_until(finished, 90, "the mission finished", 0.5)
    assert ended["state"] == "succeeded", ended["summary"]
    pose = await stack.nav("get_pose", {})
    assert pose["at_location"] == "kitchen", pose  # words = world: robot-sim's pose
    assert "lost contact with my base for a moment" in await said(http, mission_id)


async def test_robot_sim_killed_mid_drive_is_a_lost_base_and_its_return_is_reported(
    stack: Stack, http: httpx.AsyncClient
) -> None:
    mission_id = await drive(stack, http, "meeting room")
    await async_wait_until(away_from_dock(stack.watch), 30, "the robot 1 m from the dock", 0.1)

    killed = kill9(stack, "robot_sim")

    async def base_lost() -> bool:
        steps = (await mission(http, mission_id))["steps"]
        return any("BASE_UNAVAILABLE" in (s.get("detail") or "") for s in steps)

    await async_wait_until(base_lost, 30, "the drive ended as a lost base", 0.1)
    ended = time.time()
    assert ended - killed <= LOST_BASE_WITHIN_S, f"reported {ended - killed:.2f} s after"
    pose = await stack.nav("get_pose", {})
    assert pose["stale"] is True, pose
    assert pose["moving"] is False
    assert "stopped answering" in pose["pose_note"]

    stack.services.start(stack.services.specs["robot_sim"])  # it starts again at the dock

    async def relocated() -> Any:
        pose = await stack.nav("get_pose", {})
        return pose if pose.get("relocated") and not pose["stale"] else None

    pose = await async_wait_until(relocated, 60, "the base back, relocated", 0.5)
    assert pose["at_location"] == "dock"
    assert "came back" in pose["pose_note"]
    await end_mission(http)
