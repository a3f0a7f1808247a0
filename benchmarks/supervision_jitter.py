"""Supervision on a busy brain (issue 39): lease renewal jitter, lapses with the brain alive,
and the missions route, idle and under load.

On one start of the local stack (robot-sim, memory, navigation, manipulation, the brain on the
dev preset: rules chat + rules planner, robot-sim at time scale 1), per phase (the brain is
restarted before each, so its renewal statistics are the phase's own):

- ``idle``: nothing runs for ``--seconds``;
- ``busy``: two busy loops (``python -c 'while True: pass'``, started here and killed by PID)
  and, for ``--seconds``, missions through the brain (``go to the kitchen`` / ``... mailroom``
  by chat) with a burst of 20 concurrent chat turns every ``--burst-every`` seconds and the
  running mission fetched (``GET /api/agent/missions/{id}``) every 0.5 s.

Per phase: the brain's renewal gaps (between answered renewals of one server: what a server
sees; a gap over the TTL is a lapse) and lateness (a periodic renewal's start against its
schedule), from readyz ``data.supervision.renewals``; lapses with the brain alive
(``supervision_lapsed`` in the motion servers' logs) and missions recovered from one
(``supervision_lapse_recovered`` in the brain's); the missions route's latency.
The dead-man bound (brain ``kill -9`` → halted) is ``supervision_halt.py --only brain``.

``--runners process,thread`` runs every phase with each of the brain's lease runners
(``control.lease_runner``: a child process of the brain, or a thread of it), one after the other
on the same stack, and prints them side by side.

Run: ``uv run python benchmarks/supervision_jitter.py [--seconds 60] [--phases idle,busy]
[--runners process,thread]``.
Writes benchmarks/results/supervision_jitter.json.
"""

from __future__ import annotations

import argparse
import asyncio
import dataclasses
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import httpx

from robot_stack_testing import async_wait_until
from robot_stack_testing.mission_driver import fresh_secret, stack_env
from robot_stack_testing.stack import LocalStack, free_port_overrides, local_stack, stack_defaults

ROOT = Path(__file__).resolve().parents[1]
STACK_FILE = ROOT / "deploy" / "local-stack.yaml"
RESULTS = Path(__file__).with_name("results")
PLACES = ["kitchen", "mailroom"]
BURST = 20
# A control beside the brain: another process sleeping the lease's period, so a renewal's
# lateness can be told apart from the whole machine's (load from outside the stack)
PROBE = """
import json, sys, time
late, end = [], time.monotonic() + float(sys.argv[1])
while time.monotonic() < end:
    before = time.monotonic()
    time.sleep(0.25)
    late.append(max(0.0, time.monotonic() - before - 0.25))
print(json.dumps(late))
"""


def percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, max(0, round(q * (len(ordered) - 1))))]


def summary_ms(values: list[float]) -> dict[str, Any]:
    if not values:
        return {"n": 0}
    ms = [v * 1000 for v in values]
    return {
        "n": len(ms),
        "p50_ms": round(percentile(ms, 0.5), 1),
        "p95_ms": round(percentile(ms, 0.95), 1),
        "p99_ms": round(percentile(ms, 0.99), 1),
        "max_ms": round(max(ms), 1),
    }


def busy_loops(count: int) -> list[subprocess.Popen[bytes]]:
    return [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(count)]


def control_probe(seconds: float) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [sys.executable, "-c", PROBE, str(seconds)], stdout=subprocess.PIPE, text=True
    )


def end(processes: list[subprocess.Popen[bytes]]) -> None:
    for process in processes:  # only the loops this script started, by PID
        process.kill()
        process.wait(timeout=10)


def log_size(services: LocalStack, name: str) -> int:
    path = services[name].log_path
    return path.stat().st_size if path.exists() else 0


def log_count(services: LocalStack, name: str, start: int, event: str) -> int:
    path = services[name].log_path
    if not path.exists():
        return 0
    with path.open("rb") as f:
        f.seek(start)
        return f.read().decode(errors="replace").count(event)


class Phase:
    def __init__(self, services: LocalStack, brain: str) -> None:
        self.services = services
        self.http = httpx.AsyncClient(base_url=brain, timeout=60.0)
        self.fetches: list[float] = []
        self.turns: list[float] = []
        self.missions = 0
        self.arrived = 0

    async def supervised(self) -> bool:
        try:
            data = (await self.http.get("/api/readyz")).json()["data"]
        except (httpx.HTTPError, ValueError, KeyError):
            return False
        servers = (data.get("supervision") or {}).get("servers", {})
        return bool(servers) and all(
            s.get("fresh") or s.get("state") == "unsupported" for s in servers.values()
        )

    async def renewals(self) -> dict[str, Any]:
        data = (await self.http.get("/api/readyz")).json()["data"]
        supervision = data.get("supervision") or {}
        return {**supervision.get("renewals", {}), "runner": supervision.get("runner")}

    async def chat(self, text: str) -> dict[str, Any]:
        started = time.monotonic()
        answer = (await self.http.post("/api/chat", json={"text": text})).json()
        self.turns.append(time.monotonic() - started)
        return dict(answer)

    async def fetch(self, mission_id: str) -> dict[str, Any]:
        started = time.monotonic()
        body = (await self.http.get(f"/api/agent/missions/{mission_id}")).json()
        self.fetches.append(time.monotonic() - started)
        return dict(body)

    async def missions_under_bursts(self, seconds: float, burst_every: float) -> None:
        deadline = time.monotonic() + seconds
        turn = 0
        while time.monotonic() < deadline:
            place = PLACES[turn % len(PLACES)]
            turn += 1
            answer = await self.chat(f"go to the {place}")
            mission_id = answer.get("mission_id")
            if not mission_id:
                await asyncio.sleep(1.0)
                continue
            self.missions += 1
            next_burst = time.monotonic()
            state = "running"
            while time.monotonic() < deadline + 120:
                if time.monotonic() >= next_burst and time.monotonic() < deadline:
                    await asyncio.gather(*(self.chat("hello there") for _ in range(BURST)))
                    next_burst = time.monotonic() + burst_every
                state = (await self.fetch(mission_id)).get("state", "running")
                if state not in ("planning", "running", "paused", "awaiting_approval"):
                    break
                await asyncio.sleep(0.5)
            self.arrived += state == "succeeded"


def restart_brain(services: LocalStack, runner: str) -> None:
    """The brain again (its renewal statistics start afresh), with ``runner``'s lease."""
    spec = services.specs["brain"]
    env = {**spec.env, "RVC_CONFIG_OVERRIDES": f"control.lease_runner={runner}"}
    services.launcher.stop(services["brain"])
    services.start(dataclasses.replace(spec, env=env))


async def phase(
    services: LocalStack,
    brain: str,
    name: str,
    busy: int,
    seconds: float,
    burst_every: float,
    runner: str,
) -> dict[str, Any]:
    restart_brain(services, runner)
    bench = Phase(services, brain)
    await async_wait_until(bench.supervised, 90, "every motion server supervised", 0.2)
    latched = (await bench.http.get("/api/safety")).json()
    if latched.get("latched"):  # e.g. an alarm in the phase before: noted, then cleared
        await bench.http.post("/api/safety/clear", json={"reason": "benchmark: next phase"})
    logs = {n: log_size(services, n) for n in ("navigation", "manipulation", "brain")}
    loops = busy_loops(busy)
    load_before = os.getloadavg()
    probe = control_probe(seconds)
    try:
        if busy:
            await bench.missions_under_bursts(seconds, burst_every)
        else:
            await asyncio.sleep(seconds)
        renewals = await bench.renewals()
        safety = (await bench.http.get("/api/safety")).json()
        out, _ = await asyncio.to_thread(probe.communicate, timeout=seconds + 60)
        control = [float(v) for v in json.loads(out or "[]")]
    finally:
        end(loops)
        if probe.poll() is None:
            probe.kill()
            probe.wait(timeout=10)
        await bench.http.aclose()
    lapses = {
        n: log_count(services, n, logs[n], "supervision_lapsed")
        for n in ("navigation", "manipulation")
    }
    result = {
        "phase": name,
        "runner": runner,
        "busy_loops": busy,
        "seconds": seconds,
        "load_average_before": [round(v, 2) for v in load_before],
        "load_average_after": [round(v, 2) for v in os.getloadavg()],
        "renewals": renewals,
        "control_process_sleep_late": summary_ms(control),
        "lapses_with_brain_alive": lapses,
        "latched_at_start": latched.get("reason") if latched.get("latched") else None,
        "latched_at_end": safety.get("reason") if safety.get("latched") else None,
        "alarms": log_count(services, "brain", logs["brain"], '"supervision_alarm"'),
        "lapses_recovered": log_count(
            services, "brain", logs["brain"], "supervision_lapse_recovered"
        ),
        "missions": bench.missions,
        "missions_succeeded": bench.arrived,
        "missions_route": summary_ms(bench.fetches),
        "chat_turns": summary_ms(bench.turns),
    }
    print(json.dumps(result, indent=1))
    return result


async def run(args: argparse.Namespace) -> dict[str, Any]:
    placeholders = {
        **stack_defaults(STACK_FILE),
        **free_port_overrides(STACK_FILE),
        "nav_time_scale": "1",
        "brain_config_overrides": "",
        "reconnect_interval_s": "1",
    }
    brain = f"http://127.0.0.1:{placeholders['brain_port']}"
    phases = {"idle": 0, "busy": 2}
    results = []
    with tempfile.TemporaryDirectory() as scratch:
        tmp = args.keep or scratch
        env = stack_env(fresh_secret())
        if args.asyncio_debug:  # every process logs callbacks that held its loop > 100 ms
            env["PYTHONASYNCIODEBUG"] = "1"
        with local_stack(
            ROOT,
            Path(tmp) / "var",
            env,
            overrides=placeholders,
            only={"robot_sim", "memory", "navigation", "manipulation", "brain"},
        ) as services:
            for name in [p.strip() for p in args.phases.split(",") if p.strip()]:
                for runner in [r.strip() for r in args.runners.split(",") if r.strip()]:
                    results.append(
                        await phase(
                            services,
                            brain,
                            name,
                            phases[name],
                            args.seconds,
                            args.burst_every,
                            runner,
                        )
                    )
    side_by_side(results)
    return {
        "benchmark": "supervision_jitter",
        "settings": {"lease_period_s": 0.25, "lease_ttl_s": 0.8, "runners": args.runners},
        "phases": results,
    }


def side_by_side(results: list[dict[str, Any]]) -> None:
    """One line per phase and runner: the figures to compare."""
    print("phase  runner   load(1m)  late p50/p99/max ms  gap p99/max ms  lapses  probe max ms")
    for r in results:
        n = r["renewals"]
        lapses = sum(r["lapses_with_brain_alive"].values())
        print(
            f"{r['phase']:<6} {r['runner']:<8} {r['load_average_after'][0]:>8}  "
            f"{n.get('late_p50_ms')}/{n.get('late_p99_ms')}/{n.get('late_max_ms'):<10} "
            f"{n.get('gaps_p99_ms')}/{n.get('gaps_max_ms'):<10} {lapses:>6}  "
            f"{r['control_process_sleep_late'].get('max_ms')}"
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=60.0)
    parser.add_argument("--burst-every", type=float, default=10.0)
    parser.add_argument("--phases", default="idle,busy")
    parser.add_argument("--runners", default="thread,process", help="thread, process or both: a,b")
    parser.add_argument("--asyncio-debug", action="store_true", help="profile slow callbacks")
    parser.add_argument("--keep", default="", help="a directory for the stack's logs (kept)")
    args = parser.parse_args()
    result = asyncio.run(run(args))
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / "supervision_jitter.json").write_text(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
