"""A busy brain is not a dead one (issue 39 item 1), on the whole local stack with the dev preset
(rules chat + rules planner): "fetch the package from the mailroom and bring it to reception"
(a drive, a pick, a carry, a place) while the brain's loop is kept busy in bursts — 20
concurrent chat turns as each drive starts (to the mailroom, and the carry to reception), two
seconds apart — and a CPU hog runs beside it.

The lease renews from a thread of its own, so the motion servers see no lapse; if one happens
all the same (the host itself starved), the mission re-issues the cancelled step once and
goes on. Either way the package arrives: checked in robot-sim's world, not in the robot's words.
"""

from __future__ import annotations

import asyncio
import contextlib
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest

from robot_stack_testing.mission_driver import (
    MissionDriver,
    RunningStack,
    mailroom_stack,
    sim_world,
)
from robot_stack_testing.stack import free_port_overrides

pytestmark = [pytest.mark.ros, pytest.mark.slow, pytest.mark.timeout(420)]

ROOT = Path(__file__).resolve().parents[2]
STACK_FILE = ROOT / "deploy" / "local-stack.yaml"
FETCH = "fetch the package from the mailroom and bring it to reception"
BURST = 20
BURSTS_PER_DRIVE = 2
BURST_EVERY_S = 2.0


@pytest.fixture
def stack(tmp_path: Path) -> Iterator[RunningStack]:
    overrides = {
        **free_port_overrides(STACK_FILE),
        "nav_time_scale": "5",  # drives long enough for several bursts
        "brain_config_overrides": "",  # the dev preset as shipped: rules, no recording
    }
    with mailroom_stack(ROOT, tmp_path / "var", overrides) as running:
        yield running


@pytest.fixture
def cpu_hog() -> Iterator[subprocess.Popen[bytes]]:
    hog = subprocess.Popen([sys.executable, "-c", "while True: pass"])
    try:
        yield hog
    finally:
        hog.kill()  # the one process this test started, by PID
        hog.wait(timeout=10)


def running_drives(user: MissionDriver) -> set[str]:
    """Ids of the drive steps the UI has seen running."""
    return {
        step["id"]
        for plan in user.record.of("mission_plan")
        for step in plan["steps"]
        if step.get("status") == "running" and "navigate_to" in str(step.get("tool"))
    }


async def bursts(user: MissionDriver, brain: str, stop: asyncio.Event) -> int:
    """As each drive starts: 20 concurrent chat turns, twice, two seconds apart (every turn
    during a mission also reaches its planner, so the bursts are bounded); until ``stop``.
    Returns the turns sent."""
    sent, seen = 0, set()
    async with httpx.AsyncClient(base_url=brain, timeout=60.0) as http:
        while not stop.is_set():
            new = running_drives(user) - seen
            seen |= new
            for _ in range(BURSTS_PER_DRIVE if new else 0):
                answers = await asyncio.gather(
                    *(http.post("/api/chat", json={"text": "hello there"}) for _ in range(BURST)),
                    return_exceptions=True,
                )
                sent += len(answers)
                await asyncio.sleep(BURST_EVERY_S)
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(stop.wait(), 0.2)
    return sent


def count(log: str, event: str, *also: str) -> int:
    return sum(
        1
        for line in log.splitlines()
        if f'"event": "{event}"' in line and all(part in line for part in also)
    )


async def test_a_fetch_under_bursts_and_a_cpu_hog_arrives(
    stack: RunningStack, cpu_hog: subprocess.Popen[bytes]
) -> None:
    async with MissionDriver(stack.brain_url) as user:
        await user.wait_servers_connected(60.0)
        stop = asyncio.Event()
        load = asyncio.create_task(bursts(user, stack.brain_url, stop))
        try:
            record = await user.run_mission(FETCH, timeout_s=240.0)
        finally:
            stop.set()
            sent = await load

    assert sent >= 2 * BURST  # the brain's loop was kept busy during both drives
    assert cpu_hog.poll() is None
    assert record.outcome == "succeeded", record.of("mission_finished")
    drives = [r for r in record.tool_results("navigation.navigate_to") if not r["is_error"]]
    assert drives, "no drive"
    # words = world: robot-sim's own parameters say where the package is now
    world = sim_world()
    assert "yellow package" in world["places"]["reception"]
    assert "yellow package" not in world["places"]["mailroom"]
    assert world["held"] is None

    # No lapse, or every lapse that cancelled a step was recovered within the mission.
    ended = sum(
        count(stack.services[name].log(), "supervision_motion_ended", '"why": "lapsed"')
        for name in ("navigation", "manipulation")
    )
    brain_log = stack.services["brain"].log()
    if ended:
        assert count(brain_log, "supervision_lapse_recovered") >= 1, "a lapse was not recovered"
    assert count(brain_log, "supervision_lapse_not_recovered") == 0
    summary = record.snapshot["summary"]
    assert "safety link" not in summary  # a recovered lapse is said once, not as the outcome
    assert not any(s["title"].startswith("Detour") for s in record.snapshot["steps"])
