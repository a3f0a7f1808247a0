"""Abort (issue 39 item 4): how fast "abort" typed during a drive halts the robot, read from ROS.

On one start of the local stack (robot-sim, memory, navigation, the brain on the dev preset as
shipped), per run: "go to the <place>" over ``POST /api/chat``, the robot seen moving on
``/amcl_pose``, then ``POST /api/chat {"text": "abort"}``. Measured:

- ``abort_reply``: the chat request's round trip (the person sees "Aborting the mission …");
- ``abort_to_halted``: from sending "abort" to the header stamp of the first ``/amcl_pose``
  message at the final position (the robot's own clock), once the pose stood still 0.5 s;
- the mission's outcome (must be ``cancelled``) and whether the stop latched (must not).

Run: ``uv run python benchmarks/abort_halt.py [--runs 10]``. Writes
benchmarks/results/abort_halt.json.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import tempfile
import time
from pathlib import Path
from typing import Any

import httpx

from robot_stack_testing import async_wait_until
from robot_stack_testing.mission_driver import fresh_secret, stack_env
from robot_stack_testing.pose_watch import AmclWatch
from robot_stack_testing.stack import free_port_overrides, local_stack, stack_defaults

ROOT = Path(__file__).resolve().parents[1]
STACK_FILE = ROOT / "deploy" / "local-stack.yaml"
RESULTS = Path(__file__).with_name("results")
PLACES = ["kitchen", "meeting_room", "mailroom", "dock", "desk_alice", "reception"]


def percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, max(0, round(q * (len(ordered) - 1))))]


def summary(values: list[float]) -> dict[str, Any]:
    if not values:
        return {"n": 0}
    ms = [v * 1000 for v in values]
    return {
        "n": len(ms),
        "p50_ms": round(percentile(ms, 0.5), 1),
        "p99_ms": round(percentile(ms, 0.99), 1),
        "max_ms": round(max(ms), 1),
    }


async def one_run(http: httpx.AsyncClient, watch: AmclWatch, place: str) -> dict[str, Any]:
    started = (await http.post("/api/chat", json={"text": f"go to the {place}"})).json()
    if started.get("route") != "mission_started":
        return {"place": place, "error": f"not started: {started}"}
    mission_id = started["mission_id"]
    await async_wait_until(watch.moving, 60, "the robot driving", 0.05)
    sent = time.time()
    reply = (await http.post("/api/chat", json={"text": "abort"})).json()
    replied = time.time()
    await async_wait_until(lambda: watch.halted_at() is not None, 30, "halted", 0.05)
    halted = watch.halted_at()
    assert halted is not None

    async def ended() -> dict[str, Any] | None:
        data: dict[str, Any] = (await http.get(f"/api/agent/missions/{mission_id}")).json()
        return data if data["state"] in ("succeeded", "failed", "cancelled") else None

    mission = await async_wait_until(ended, 30, "the mission to end", 0.1)
    latched = (await http.get("/api/safety")).json()["latched"]
    return {
        "place": place,
        "route": reply.get("route"),
        "abort_reply_s": replied - sent,
        "abort_to_halted_s": halted - sent,
        "outcome": mission["state"],
        "latched": latched,
    }


async def bench(runs: int) -> dict[str, Any]:
    placeholders = {
        **stack_defaults(STACK_FILE),
        **free_port_overrides(STACK_FILE),
        "nav_time_scale": "1",
        "brain_config_overrides": "",
    }
    brain = f"http://127.0.0.1:{placeholders['brain_port']}"
    watch = AmclWatch()
    rows: list[dict[str, Any]] = []
    try:
        with (
            tempfile.TemporaryDirectory() as tmp,
            local_stack(
                ROOT,
                Path(tmp) / "var",
                stack_env(fresh_secret()),
                overrides=placeholders,
                only={"robot_sim", "memory", "navigation", "brain"},
            ),
        ):
            async with httpx.AsyncClient(base_url=brain, timeout=30.0) as http:

                async def navigation_up() -> bool:
                    data = (await http.get("/api/readyz")).json()["data"]
                    return bool(data["mcp_servers"].get("navigation") == "connected")

                await async_wait_until(navigation_up, 90, "navigation connected", 0.2)
                for i in range(runs):
                    await async_wait_until(
                        lambda: watch.halted_at() is not None, 30, "still before a run", 0.05
                    )
                    row = await one_run(http, watch, PLACES[i % len(PLACES)])
                    rows.append(row)
                    print(json.dumps(row), flush=True)
    finally:
        watch.close()
    good = [r for r in rows if "error" not in r]
    return {
        "runs": len(rows),
        "cancelled": sum(r.get("outcome") == "cancelled" for r in good),
        "latched": sum(bool(r.get("latched")) for r in good),
        "abort_reply": summary([r["abort_reply_s"] for r in good]),
        "abort_to_halted": summary([r["abort_to_halted_s"] for r in good]),
        "rows": rows,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=10)
    args = parser.parse_args()
    result = asyncio.run(bench(args.runs))
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / "abort_halt.json").write_text(json.dumps(result, indent=2) + "\n")
    print(json.dumps({k: v for k, v in result.items() if k != "rows"}, indent=2))


if __name__ == "__main__":
    main()
