"""Benchmark: "fetch the package from the mailroom and bring it to reception" end to end on the
whole local stack (deploy/local-stack.yaml on free ports, the dev preset's rules planner,
robot-sim as the robot, time scale 10), timed per phase from the UI's own mission_plan
snapshots: each plan step from running to its end (drive, look, pick, read back, carry,
place, confirm), plus instruction → first step running and → mission_finished. The world is
checked afterwards from robot-sim's parameters. Writes benchmarks/results/fetch_mission.json.

    uv run python benchmarks/fetch_mission.py [--runs 3]
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import random
import sys
import tempfile
import time
from datetime import datetime
from pathlib import Path
from typing import Any

from robot_stack_testing.mission_driver import MissionDriver, mailroom_stack, sim_world
from robot_stack_testing.stack import free_port_overrides

ROOT = Path(__file__).resolve().parents[1]
STACK_FILE = ROOT / "deploy" / "local-stack.yaml"
RESULTS = Path(__file__).parent / "results" / "fetch_mission.json"
FETCH = "fetch the package from the mailroom and bring it to reception"


class TimedEvents(list[tuple[str, Any]]):
    """The driver's event list, with when each event arrived."""

    def __init__(self) -> None:
        super().__init__()
        self.times: list[float] = []

    def append(self, item: tuple[str, Any]) -> None:
        super().append(item)
        self.times.append(time.monotonic())


def phases(events: TimedEvents, sent: float) -> dict[str, Any]:
    """Per step: title and seconds from running to its terminal status (first time seen)."""
    began: dict[str, float] = {}
    ended: dict[str, tuple[float, str, str]] = {}
    finished = None
    for (name, data), at in zip(events, events.times, strict=True):
        if name == "mission_finished":
            finished = at
        if name != "mission_plan":
            continue
        for step in data.get("steps", []):
            sid, status = step["id"], step["status"]
            if status == "running":
                began.setdefault(sid, at)
            elif status in ("succeeded", "failed", "skipped") and sid not in ended:
                ended[sid] = (at, status, step["title"])
    steps = {
        sid: {
            "title": title,
            "status": status,
            "seconds": round(at - began.get(sid, at), 3),
        }
        for sid, (at, status, title) in ended.items()
    }
    first = min(began.values(), default=sent)
    return {
        "instruction_to_first_step_s": round(first - sent, 3),
        "total_s": round((finished or sent) - sent, 3),
        "steps": steps,
    }


async def one_run(brain_url: str) -> dict[str, Any]:
    async with MissionDriver(brain_url) as user:
        await user.wait_servers_connected(60.0)
        timed = TimedEvents()
        user.record.events = timed
        sent = time.monotonic()
        record = await user.run_mission(FETCH, timeout_s=240.0)
    result = phases(timed, sent)
    result["outcome"] = record.outcome
    result["summary"] = record.snapshot.get("summary")
    return result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=2)
    args = parser.parse_args()
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    os.environ.setdefault("ROS_DOMAIN_ID", str(random.randint(120, 200)))
    load = os.getloadavg()
    runs = []
    for n in range(args.runs):
        var = Path(tempfile.mkdtemp(prefix="bench-fetch-"))
        overrides = {
            **free_port_overrides(STACK_FILE),
            "nav_time_scale": "10",
            "brain_config_overrides": "",  # the dev preset as shipped: rules planner
        }
        with mailroom_stack(ROOT, var, overrides) as stack:
            result = asyncio.run(one_run(stack.brain_url))
            placed = sim_world()["places"]
            result["package_at_reception"] = "yellow package" in placed["reception"]
            result["package_left_mailroom"] = "yellow package" not in placed["mailroom"]
        runs.append(result)
        print(f"run {n}: {result['outcome']} in {result['total_s']} s", file=sys.stderr)
    report = {
        "benchmark": "fetch_mission",
        "instruction": FETCH,
        "nav_time_scale": 10,
        "load_average_at_start": [round(v, 2) for v in load],
        "measured_at": datetime.now().isoformat(timespec="seconds"),
        "runs": runs,
    }
    RESULTS.parent.mkdir(parents=True, exist_ok=True)
    RESULTS.write_text(json.dumps(report, indent=2) + "\n")
    for n, run in enumerate(runs):
        print(f"run {n}: {run['outcome']}, {run['total_s']} s end to end")
        for sid, step in run["steps"].items():
            print(f"  {sid:5} {step['title']:38} {step['status']:10} {step['seconds']:7.2f} s")
    print(f"load average at start {load[0]:.1f}; JSON: {RESULTS}")


if __name__ == "__main__":
    main()
