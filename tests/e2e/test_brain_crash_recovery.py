"""kill -9 of the brain mid-drive, then a restart (issue 23 item 3): the mission the dead
process left ``running`` is closed as interrupted by the restart, its drive is cancelled at the
navigation server (the robot stops), and the events the navigation outbox delivers to the new
brain are acknowledged, not retried forever. Issue 27: the robot does not wait for the restart
— its lease lapses and robot-sim's ``/amcl_pose`` stops changing (benchmarks: within 1 s).
Real OS processes from deploy/local-stack.yaml: robot-sim (Nav2 as navigation drives it,
honouring the supervisor lock), memory, navigation and the brain on the dev preset (rules)."""

from __future__ import annotations

import os
import signal
import sqlite3
import time
from pathlib import Path
from typing import Any

import httpx
import pytest

from robot_stack_testing import async_wait_until
from robot_stack_testing.mission_driver import call_mcp, fresh_secret, stack_env
from robot_stack_testing.pose_watch import AmclWatch
from robot_stack_testing.stack import free_port_overrides, local_stack, stack_defaults

pytestmark = [pytest.mark.slow, pytest.mark.ros, pytest.mark.timeout(300)]
# tells "halted" from "drove on until the restarted brain cancelled" (≥ 9 s) on a loaded shared
# host; the 1 s bound itself is a speed goal, measured in benchmarks/supervision_halt.py
HALTED_WITHIN_S = 3.0

ROOT = Path(__file__).resolve().parents[2]
STACK_FILE = ROOT / "deploy" / "local-stack.yaml"


def outbox_rows(path: Path) -> tuple[int, int]:
    """(events still to deliver, dead letters) of a stopped server's outbox."""
    db = sqlite3.connect(path, timeout=5)
    try:
        events = int(db.execute("SELECT COUNT(*) FROM events").fetchone()[0])
        dead = int(db.execute("SELECT COUNT(*) FROM dead_letters").fetchone()[0])
        return events, dead
    finally:
        db.close()


@pytest.fixture
def watch() -> Any:
    amcl = AmclWatch()
    yield amcl
    amcl.close()


async def test_kill_9_of_the_brain_mid_drive_closes_the_mission_and_stops_the_robot(
    tmp_path: Path, watch: AmclWatch
) -> None:
    var = tmp_path / "var"
    placeholders = {
        **stack_defaults(STACK_FILE),
        **free_port_overrides(STACK_FILE),
        "nav_time_scale": "1",  # a drive that outlasts the crash and the restart
        "brain_config_overrides": "",  # the dev preset as shipped: rules, no keys
        "reconnect_interval_s": "1",
    }
    brain_url = f"http://127.0.0.1:{placeholders['brain_port']}"
    nav_sse = f"http://127.0.0.1:{placeholders['navigation_port']}/sse"
    with local_stack(
        ROOT,
        var,
        stack_env(fresh_secret()),
        overrides=placeholders,
        only={"robot_sim", "memory", "navigation", "brain"},
    ) as services:
        nav_token = services.credentials["navigation"]
        async with httpx.AsyncClient(base_url=brain_url, timeout=30.0) as http:

            async def navigation_connected() -> bool:
                ready = (await http.get("/api/readyz")).json()["data"]["mcp_servers"]
                return bool(ready.get("navigation") == "connected")

            async def snapshot() -> dict[str, Any]:
                answer = await http.get(f"/api/agent/missions/{mission_id}")
                data: dict[str, Any] = answer.json()
                return data

            await async_wait_until(navigation_connected, 60, "navigation adopted", interval_s=0.2)
            started = (await http.post("/api/chat", json={"text": "go to the kitchen"})).json()
            assert started["route"] == "mission_started", started
            mission_id = started["mission_id"]

            async def driving() -> bool:  # the plan comes once the planner read the places
                steps = (await snapshot())["steps"]
                return bool(steps and steps[0]["status"] == "running" and "%" in steps[0]["detail"])

            await async_wait_until(driving, 60, "the drive reports progress", interval_s=0.2)
            task_id = (await snapshot())["steps"][0]["task_id"]
            assert task_id

            await async_wait_until(watch.moving, 30, "the robot driving", interval_s=0.1)
            brain = services["brain"]
            os.kill(brain.pid, signal.SIGKILL)
            killed = time.time()
            brain.popen.wait(timeout=10)
            # the lease lapses: navigation cancels and locks, robot-sim's twist_mux lock holds
            await async_wait_until(lambda: watch.halted_at() is not None, 20, "the halt", 0.1)
            halted = watch.halted_at()
            assert halted is not None
            assert halted - killed <= HALTED_WITHIN_S, f"halted {halted - killed:.2f} s after"
            restarted = services.start(services.specs["brain"])

            async def closed() -> bool:
                return bool((await snapshot())["state"] == "failed")

            await async_wait_until(closed, 60, "the mission closed", interval_s=0.2)
            snap = await snapshot()
            assert "interrupted by a restart" in snap["summary"]
            first = snap["steps"][0]
            assert (first["status"], first["detail"]) == ("failed", "interrupted by a restart")
            assert all(s["status"] in ("failed", "skipped") for s in snap["steps"])
            assert (await http.get("/api/agent/missions")).json()["active"] is None

            async def drive_cancelled() -> bool:
                task = await call_mcp(nav_sse, "get_task", {"task_id": task_id}, token=nav_token)
                return bool(task.get("state") == "cancelled")

            await async_wait_until(drive_cancelled, 60, "the drive cancelled", interval_s=0.5)
            running = await call_mcp(
                nav_sse, "list_tasks", {"states": ["running"]}, token=nav_token
            )
            assert running["tasks"] == [], running

            # the late events of the dead mission reach the new brain and are acknowledged,
            # the last one (the drive's cancellation) included
            def acknowledged() -> bool:
                return any(
                    "agent_event_interrupted_mission" in line and "task_failed" in line
                    for line in restarted.log().splitlines()
                )

            await async_wait_until(acknowledged, 60, "late events acknowledged", interval_s=0.5)
        # stopped (by PID), the navigation server releases its outbox: nothing left to retry
        services.launcher.stop(services["navigation"])
        assert outbox_rows(var / "navigation-outbox.sqlite3") == (0, 0)
