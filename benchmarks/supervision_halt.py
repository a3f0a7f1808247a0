"""Supervision (issue 27): how fast the robot halts when its supervision goes, read from ROS.

On one start of the local stack (robot-sim honouring the supervisor lock, memory, navigation,
the brain on the dev preset), per run: a drive is started (``navigate_to`` from this script, a
local MCP client, while the brain supervises), the robot is seen moving on ``/amcl_pose``,
then one of

- ``brain``: ``kill -9`` of the brain → its lease lapses (0.8 s TTL) → navigation cancels and
  locks → robot-sim's twist_mux lock halts the base; the brain is restarted after each run;
- ``navigation``: ``kill -9`` of the navigation server → its lock falls silent → robot-sim
  halts after the lock's 0.5 s timeout; navigation is restarted after each run;
- ``stop``: ``POST /api/safety/stop`` → the brain cancels, calls the stop tool and sends the
  latched lease; cleared again after each run;
- ``base``: ``kill -9`` of robot-sim → navigation ends the drive ``BASE_UNAVAILABLE`` (no
  NavigateToPose feedback for 3 s); measured to the task's failure as ``get_task`` shows it;
  robot-sim is restarted after each run.

"Halted" is the header stamp of the first ``/amcl_pose`` message at the final position (the
robot's own clock, stamps compare with ``time.time()``), once the pose has stood still 0.5 s.

Run: ``uv run python benchmarks/supervision_halt.py [--runs 20] [--only brain,stop,base]``.
Writes benchmarks/results/supervision_halt.json.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import signal
import tempfile
import time
from collections.abc import Awaitable, Callable
from pathlib import Path
from typing import Any

import httpx

from robot_stack_testing import async_wait_until
from robot_stack_testing.mission_driver import call_mcp, fresh_secret, stack_env
from robot_stack_testing.pose_watch import AmclWatch
from robot_stack_testing.stack import LocalStack, free_port_overrides, local_stack, stack_defaults

ROOT = Path(__file__).resolve().parents[1]
STACK_FILE = ROOT / "deploy" / "local-stack.yaml"
RESULTS = Path(__file__).with_name("results")
NAMES = {
    "brain": "brain_kill_to_halted",
    "navigation": "navigation_kill_to_halted",
    "stop": "stop_to_halted",
    "base": "robot_sim_kill_to_base_unavailable",
}
PLACES = ["meeting_room", "dock", "mailroom", "desk_alice", "kitchen", "corridor_b"]


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
        "min_ms": round(min(ms), 1),
    }


class Bench:
    def __init__(self, services: LocalStack, brain: str, navigation: str, watch: AmclWatch):
        self.services = services
        self.brain = brain
        self.navigation = navigation
        self.watch = watch
        self.http = httpx.AsyncClient(base_url=brain, timeout=30.0)
        self.turn = 0

    async def nav(self, tool: str, arguments: dict[str, Any]) -> Any:
        """navigation's tool as another local client: an operator's tool, own credential."""
        token = self.services.operator_credentials["navigation"]
        return await call_mcp(self.navigation, tool, arguments, token=token)

    async def supervised(self) -> bool:
        try:
            data = (await self.http.get("/api/readyz")).json()["data"]
        except httpx.HTTPError:
            return False
        lease = (data.get("supervision") or {}).get("servers", {}).get("navigation", {})
        return bool(lease.get("fresh"))

    async def drive(self) -> None:
        """A drive from this client, once the brain supervises and the stop is clear: the
        next place of the list that takes the goal and gets the robot moving."""
        await async_wait_until(self.supervised, 90, "navigation supervised", 0.1)
        if (await self.http.get("/api/safety")).json()["latched"]:
            await self.http.post("/api/safety/clear", json={"reason": "benchmark: clear"})
        await async_wait_until(lambda: self.watch.halted_at(0.2) is not None, 30, "still", 0.05)
        for _ in range(3 * len(PLACES)):
            place = PLACES[self.turn % len(PLACES)]
            self.turn += 1
            answer = await self.nav("navigate_to", {"location": place})
            if "task_id" not in answer:  # busy, or the clear's lease not there yet
                await asyncio.sleep(0.5)
                continue
            try:
                await async_wait_until(self.watch.moving, 5, "the robot driving", 0.02)
                return
            except TimeoutError:  # already there: stop it and take the next place
                await self.nav("stop_navigation", {})
        raise RuntimeError("no drive got the robot moving")

    async def halt_after(self, action: Callable[[], Awaitable[float]]) -> float:
        started = await action()
        await async_wait_until(lambda: self.watch.halted_at() is not None, 30, "the halt", 0.05)
        halted = self.watch.halted_at()
        assert halted is not None
        return halted - started

    def kill9(self, name: str) -> float:
        process = self.services[name]
        os.kill(process.pid, signal.SIGKILL)
        killed = time.time()
        process.popen.wait(timeout=10)
        return killed

    async def brain_run(self) -> float:
        await self.drive()

        async def kill() -> float:
            return self.kill9("brain")

        took = await self.halt_after(kill)
        self.services.start(self.services.specs["brain"])
        return took

    async def navigation_run(self) -> float:
        await self.drive()

        async def kill() -> float:
            return self.kill9("navigation")

        took = await self.halt_after(kill)
        self.services.start(self.services.specs["navigation"])
        return took

    async def base_run(self) -> float:
        """kill -9 of robot-sim → the drive's task failed BASE_UNAVAILABLE (seconds)."""
        await self.drive()
        running = await self.nav("list_tasks", {"states": ["running"]})
        (task,) = running["tasks"]
        killed = self.kill9("robot_sim")

        async def lost() -> float | None:
            info = await self.nav("get_task", {"task_id": task["task_id"]})
            error = info.get("error") or {}
            return time.time() if error.get("error_code") == "BASE_UNAVAILABLE" else None

        reported = await async_wait_until(lost, 60, "BASE_UNAVAILABLE", 0.05)
        assert reported is not None
        self.services.start(self.services.specs["robot_sim"])
        return reported - killed

    async def stop_run(self) -> float:
        await self.drive()

        async def stop() -> float:
            sent = time.time()
            await self.http.post("/api/safety/stop", json={"reason": "benchmark"})
            return sent

        return await self.halt_after(stop)


async def run(args: argparse.Namespace) -> dict[str, Any]:
    modes = [m.strip() for m in args.only.split(",") if m.strip()]
    placeholders = {
        **stack_defaults(STACK_FILE),
        **free_port_overrides(STACK_FILE),
        "nav_time_scale": "1",
        "brain_config_overrides": "",
        "reconnect_interval_s": "1",
    }
    results: dict[str, list[float]] = {mode: [] for mode in modes}
    load_before = os.getloadavg()
    with tempfile.TemporaryDirectory() as scratch:
        tmp = args.keep or scratch
        watch = AmclWatch()
        try:
            with local_stack(
                ROOT,
                Path(tmp) / "var",
                stack_env(fresh_secret()),
                overrides=placeholders,
                only={"robot_sim", "memory", "navigation", "brain"},
            ) as services:
                bench = Bench(
                    services,
                    f"http://127.0.0.1:{placeholders['brain_port']}",
                    f"http://127.0.0.1:{placeholders['navigation_port']}/sse",
                    watch,
                )
                for mode in modes:
                    runner = getattr(bench, f"{mode}_run")
                    for index in range(args.runs):
                        took = await runner()
                        results[mode].append(took)
                        print(
                            f"{mode} {index + 1}/{args.runs}: halted {took * 1000:.0f} ms after"
                            f" (at {time.time():.3f})"
                        )
                await bench.http.aclose()
        finally:
            watch.close()
    return {
        "benchmark": "supervision_halt",
        "runs": args.runs,
        "load_average_before": [round(v, 2) for v in load_before],
        "load_average_after": [round(v, 2) for v in os.getloadavg()],
        "settings": {"lease_period_s": 0.25, "lease_ttl_s": 0.8, "lock_timeout_s": 0.5},
        **{NAMES[mode]: summary(values) for mode, values in results.items()},
        "raw_s": {mode: [round(v, 4) for v in values] for mode, values in results.items()},
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=20)
    parser.add_argument("--only", default="brain,navigation,stop,base")
    parser.add_argument("--keep", default="", help="a directory for the stack's logs (kept)")
    args = parser.parse_args()
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"  # never off this machine
    os.environ.setdefault("ROS_DOMAIN_ID", str(40 + os.getpid() % 50))
    report = asyncio.run(run(args))
    RESULTS.mkdir(exist_ok=True)
    out = RESULTS / "supervision_halt.json"
    if out.exists() and args.only != parser.get_default("only"):  # --only: keep the other modes
        earlier = json.loads(out.read_text())
        report = {**earlier, **report, "raw_s": {**earlier.get("raw_s", {}), **report["raw_s"]}}
    out.write_text(json.dumps(report, indent=2))
    print(json.dumps({k: v for k, v in report.items() if k != "raw_s"}, indent=2))
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
