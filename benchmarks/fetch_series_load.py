"""Benchmark (issue 39): alternating fetches on a busy robot, confirmed in robot-sim's world.

The whole local stack (deploy/local-stack.yaml on free ports, the dev preset's rules planner,
robot-sim as the robot) runs beside two CPU-burning loops this script starts and ends by PID.
Each run asks the robot to fetch the yellow package from wherever robot-sim's world says it is
(the mailroom or reception) and bring it to the other place; while the mission runs, a burst
of chat turns (20 by default, concurrent) hits the brain. A run succeeds only if robot-sim's
world shows the package at the destination and the gripper empty — never from the brain's
report. Also counted: supervision lapses the motion servers logged (``supervision_lapsed``;
the brain stays alive throughout, so the goal is 0), the brain's RSS before and after, and
the missions route's latency during the bursts. Writes benchmarks/results/fetch_series_load.json.

    uv run python benchmarks/fetch_series_load.py [--runs 20] [--burst 20] [--busy-loops 2]
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import random
import statistics
import subprocess
import sys
import tempfile
import time
from datetime import datetime
from pathlib import Path
from typing import Any

import httpx

from robot_stack_testing.mission_driver import (
    PACKAGE_LABEL,
    MissionDriver,
    mailroom_stack,
    sim_world,
)
from robot_stack_testing.stack import free_port_overrides

ROOT = Path(__file__).resolve().parents[1]
STACK_FILE = ROOT / "deploy" / "local-stack.yaml"
RESULTS = Path(__file__).parent / "results" / "fetch_series_load.json"
PLACES = ("mailroom", "reception")
CHATTER = ("what time is it", "where are you", "hello", "what can you do", "how are you")


def rss_bytes(pid: int) -> int:
    """A process's resident set (Linux ``/proc``; psutil is not in the lock)."""
    return int(Path(f"/proc/{pid}/statm").read_text().split()[1]) * os.sysconf("SC_PAGE_SIZE")


def busy_loops(count: int) -> list[subprocess.Popen[bytes]]:
    """``count`` processes that each burn one core until ended (by PID, in ``main``)."""
    return [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(count)]


def where_is_the_package() -> str | None:
    places = sim_world()["places"]
    return next((p for p in PLACES if PACKAGE_LABEL in places.get(p, [])), None)


async def burst(brain_url: str, size: int, mission_id: str | None) -> dict[str, Any]:
    """``size`` concurrent chat turns, then the missions route timed once per turn."""
    async with httpx.AsyncClient(base_url=brain_url, timeout=60.0) as http:

        async def turn(n: int) -> int:
            response = await http.post("/api/chat", json={"text": CHATTER[n % len(CHATTER)]})
            return response.status_code

        codes = await asyncio.gather(*(turn(n) for n in range(size)))
        route_ms = []
        for _ in range(size if mission_id else 0):
            started = time.perf_counter()
            await http.get(f"/api/agent/missions/{mission_id}")
            route_ms.append((time.perf_counter() - started) * 1000)
    return {"statuses": sorted(set(codes)), "missions_route_ms": route_ms}


async def one_fetch(brain_url: str, source: str, destination: str, size: int) -> dict[str, Any]:
    request = f"fetch the yellow package from the {source} and bring it to the {destination}"
    async with MissionDriver(brain_url) as user:
        await user.wait_servers_connected(120.0)
        started = time.monotonic()
        reply = await user.send(request)
        mission_id = reply.get("mission_id")
        if not mission_id:
            return {"request": request, "started": False, "reply": reply.get("reply")}
        await asyncio.sleep(3.0)  # into the drive before the burst lands
        chatter = await burst(brain_url, size, str(mission_id))
        record = await user.wait_finished(600.0)
        return {
            "request": request,
            "started": True,
            "outcome": record.outcome,
            "seconds": round(time.monotonic() - started, 1),
            "burst": chatter,
            "said": record.robot_words()[-3:],
        }


def lapses(stack: Any) -> int:
    return sum(
        stack.services[name].log().count('"supervision_lapsed"')
        for name in ("navigation", "manipulation")
        if name in stack.services
    )


def percentile(values: list[float], q: float) -> float:
    if not values:
        return 0.0
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, round(q * (len(ordered) - 1)))]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=20)
    parser.add_argument("--burst", type=int, default=20)
    parser.add_argument("--busy-loops", type=int, default=2)
    parser.add_argument("--time-scale", default="10")
    args = parser.parse_args()
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    os.environ.setdefault("ROS_DOMAIN_ID", str(random.randint(120, 200)))
    var = Path(tempfile.mkdtemp(prefix="bench-fetch-series-"))
    overrides = {
        **free_port_overrides(STACK_FILE),
        "nav_time_scale": args.time_scale,
        "brain_config_overrides": "",  # the dev preset as shipped: rules planner
    }
    hogs = busy_loops(args.busy_loops)
    runs: list[dict[str, Any]] = []
    began = time.monotonic()
    try:
        with mailroom_stack(ROOT, var, overrides) as stack:
            brain_pid = stack.services["brain"].pid
            rss_start = rss_bytes(brain_pid)
            for n in range(args.runs):
                source = where_is_the_package() or "mailroom"
                destination = PLACES[1] if source == PLACES[0] else PLACES[0]
                result = asyncio.run(one_fetch(stack.brain_url, source, destination, args.burst))
                world = sim_world()
                result["arrived"] = PACKAGE_LABEL in world["places"].get(destination, [])
                result["gripper_empty"] = world.get("held") in (None, "")
                result["lapses_so_far"] = lapses(stack)
                runs.append(result)
                print(
                    f"run {n}: {source} -> {destination}: {result.get('outcome')}, "
                    f"arrived={result['arrived']}, lapses={result['lapses_so_far']}",
                    file=sys.stderr,
                )
            rss_end = rss_bytes(brain_pid)
            lapse_count = lapses(stack)
    finally:
        for hog in hogs:
            hog.kill()
            hog.wait()
    hours = (time.monotonic() - began) / 3600
    route = [ms for run in runs for ms in run.get("burst", {}).get("missions_route_ms", [])]
    successes = sum(1 for run in runs if run.get("arrived") and run.get("gripper_empty"))
    report = {
        "benchmark": "fetch_series_load",
        "runs": len(runs),
        "successes_in_world": successes,
        "burst": args.burst,
        "busy_loops": args.busy_loops,
        "time_scale": args.time_scale,
        "lapses_with_brain_alive": lapse_count,
        "lapses_per_hour": round(lapse_count / hours, 2) if hours else 0.0,
        "brain_rss_mb": {"start": rss_start / 2**20, "end": rss_end / 2**20},
        "missions_route_ms": {
            "p50": round(statistics.median(route), 1) if route else 0.0,
            "p95": round(percentile(route, 0.95), 1),
            "max": round(max(route, default=0.0), 1),
        },
        "load_average_end": [round(v, 2) for v in os.getloadavg()],
        "measured_at": datetime.now().isoformat(timespec="seconds"),
        "detail": runs,
    }
    RESULTS.parent.mkdir(parents=True, exist_ok=True)
    RESULTS.write_text(json.dumps(report, indent=2) + "\n")
    print(
        f"{successes}/{len(runs)} fetches confirmed in robot-sim's world; "
        f"{lapse_count} lapses ({report['lapses_per_hour']}/h) with the brain alive; "
        f"brain RSS {rss_start / 2**20:.0f} -> {rss_end / 2**20:.0f} MB; "
        f"missions route p50 {report['missions_route_ms']['p50']} ms, "
        f"p95 {report['missions_route_ms']['p95']} ms; JSON: {RESULTS}"
    )


if __name__ == "__main__":
    main()
