"""Supervision against an intruder on the ROS domain (issue 35): how fast the robot is halted and
the intrusion reported, read from ROS (robot-sim's ``/amcl_pose``) and from the supervise answer.

Processes: robot-sim (honouring its supervisor lock, as twist_mux would), the navigation server
(NAV_MOTION=nav2, supervision required, streamable-http with the brain's credential), this script
as the supervising brain (renews its lease every 0.1 s, TTL 2 s, reads the ``alarms`` of each
answer), and per run a fresh intruder process (``robot_stack_testing.navigation.intruder``).

Scenarios, each over ``--runs`` runs:

- ``spoof_drive``: the robot drives (``navigate_to``, lease clear); the intruder publishes ``false``
  on ``/robot/supervisor_lock`` at 200 Hz. Measured from the intruder's first message (its
  ``intruder_ready``, wall time) to ``alarm`` (the first supervise answer naming
  ``LOCK_TOPIC_SHARED``) and to ``halted`` (the stamp of the first ``/amcl_pose`` at the final
  position, once still 0.5 s; robot-sim stamps with the wall clock).
- ``goal_latched``: the stop latched; the intruder spoofs the lock and sends a NavigateToPose goal
  straight to robot-sim. Measured from the goal's acceptance to its cancellation (both reported
  by the intruder's own client, wall time), and how far the robot rolled meanwhile.
- ``fake_pose``: the intruder publishes a fake ``/amcl_pose``; from its ``intruder_ready`` to the
  first supervise answer naming ``POSE_TOPIC_SHARED``.

Between runs the intruder is stopped, the brain acknowledges the alarms with latched renewals and
clears the stop. "Operator told" is the brain's part (it reacts to the supervise answer's alarms);
this benchmark ends at the answer that carries the alarm.

Run: ``uv run python benchmarks/supervision_intrusion.py [--runs 20] [--only spoof_drive]``.
Writes benchmarks/results/supervision_intrusion.json.
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import json
import math
import os
import random
import signal
import sys
import tempfile
import time
from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
RESULTS = Path(__file__).with_name("results")
FAR = {(9.0, -3.0): "kitchen", (17.0, 3.0): "mailroom", (0.0, 0.0): "dock"}
"""Far-apart places: each drive goes to the one furthest from where the robot stands."""
SCENARIOS = ("spoof_drive", "goal_latched", "fake_pose")


def percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, max(0, round(q * (len(ordered) - 1))))]


def summary(values: list[float], unit: str = "ms", scale: float = 1000.0) -> dict[str, Any]:
    if not values:
        return {"n": 0}
    scaled = [v * scale for v in values]
    return {
        "n": len(scaled),
        f"p50_{unit}": round(percentile(scaled, 0.5), 3),
        f"p99_{unit}": round(percentile(scaled, 0.99), 3),
        f"max_{unit}": round(max(scaled), 3),
        f"min_{unit}": round(min(scaled), 3),
    }


class Brain:
    """The supervising brain: one lease renewal every 0.1 s; the answers' alarms, timed."""

    def __init__(self, client: Any) -> None:
        self.client = client
        self.latched = True
        self.last: dict[str, Any] = {}
        self.first_seen: dict[str, float] = {}  # alarm code -> wall time of the first answer

    async def renew_forever(self) -> None:
        while True:
            arguments = {"holder": "brain-bench", "latched": self.latched, "ttl_s": 2.0}
            result = await self.client.call_tool("supervise", arguments)
            answer = json.loads(result.content[0].text)
            now = time.time()
            if not result.is_error:
                self.last = answer
                for alarm in answer.get("alarms", []):
                    self.first_seen.setdefault(alarm["code"], now)
            await asyncio.sleep(0.1)

    def state(self, latched: bool, lock: str) -> bool:
        return self.last.get("latched") is latched and self.last.get("lock") == lock


async def wait(predicate: Any, timeout_s: float, what: str) -> Any:
    deadline = time.monotonic() + timeout_s
    while True:
        value = predicate()
        if value:
            return value
        if time.monotonic() > deadline:
            raise TimeoutError(f"timed out after {timeout_s} s waiting for {what}")
        await asyncio.sleep(0.02)


def intruder_events(process: Any, name: str) -> list[dict[str, Any]]:
    lines = [line for line in process.log().splitlines() if line.startswith("{")]
    return [e for e in (json.loads(line) for line in lines) if e.get("event") == name]


class Bench:
    def __init__(self, launcher: Any, brain: Brain, watch: Any, work: Path) -> None:
        self.launcher = launcher
        self.brain = brain
        self.watch = watch
        self.work = work
        self.count = 0

    def intruder(self, *args: str) -> tuple[Any, Path]:
        """An intruder process, started and warmed up; it intrudes once the file exists."""
        self.count += 1
        go = self.work / f"go-{self.count}"
        process = self.launcher.start(
            "intruder",
            [
                sys.executable,
                "-m",
                "robot_stack_testing.navigation.intruder",
                "--wait-for",
                str(go),
                *args,
            ],
        )
        return process, go

    async def warm(self, process: Any) -> None:
        await wait(lambda: intruder_events(process, "intruder_waiting"), 60, "the intruder")

    async def reset(self, intruder: Any) -> None:
        """The intruder gone, the alarms acknowledged (latched renewals), the stop clear."""
        self.launcher.stop(intruder)
        self.brain.latched = True
        await wait(lambda: self.brain.last.get("alarms") == [], 60, "the alarms acknowledged")
        self.brain.first_seen.clear()
        await wait(lambda: self.watch.halted_at() is not None, 60, "the robot still")

    async def clear(self) -> None:
        self.brain.latched = False
        await wait(lambda: self.brain.state(False, "open"), 30, "the lock open")

    async def spoof_drive(self) -> dict[str, float]:
        intruder, go = self.intruder("--lock-topic", "/robot/supervisor_lock", "--lock-hz", "200")
        try:
            await self.warm(intruder)
            await self.clear()
            latest = self.watch.latest()
            here = (latest.x, latest.y) if latest is not None else (0.0, 0.0)
            far = max(FAR, key=lambda xy: math.dist(xy, here))  # a drive outlasting the run
            place = FAR[far]
            started = await self.brain.client.call_tool("navigate_to", {"location": place})
            if started.is_error:
                raise AssertionError(f"navigate_to {place}: {started.content[0].text}")
            await wait(self.watch.moving, 30, "the robot driving")
            go.touch()
            ready = await wait(lambda: intruder_events(intruder, "intruder_ready"), 30, "ready")
            t0 = float(ready[0]["wall"])
            alarm = await wait(
                lambda: self.brain.first_seen.get("LOCK_TOPIC_SHARED"), 30, "the alarm"
            )
            halted = await wait(self.watch.halted_at, 30, "the halt")
            if halted < t0:
                raise AssertionError("the robot had stopped before the intrusion began")
        finally:
            await self.reset(intruder)
        return {"alarm": alarm - t0, "halted": halted - t0}

    async def goal_latched(self) -> dict[str, float]:
        self.brain.latched = True
        await wait(lambda: self.brain.state(True, "locked"), 30, "latched")
        latest = self.watch.latest()
        origin = (latest.x, latest.y)
        goal = random.choice([(9.0, -3.0), (17.0, 3.0), (0.0, 0.0), (4.0, 1.5)])
        if math.dist(goal, origin) < 2:
            goal = (9.0, -3.0) if math.dist((9.0, -3.0), origin) > 2 else (0.0, 0.0)
        intruder, go = self.intruder(
            "--lock-topic", "/robot/supervisor_lock", "--goal", f"{goal[0]},{goal[1]}"
        )
        try:
            await self.warm(intruder)
            go.touch()
            accepted = await wait(lambda: intruder_events(intruder, "goal_accepted"), 60, "goal")
            ended = await wait(lambda: intruder_events(intruder, "goal_ended"), 60, "its end")
            if ended[0]["status"] != "canceled":
                raise AssertionError(f"the intruder's goal ended {ended[0]['status']}")
            await wait(self.watch.halted_at, 30, "the robot still")
            rolled = max(
                (math.dist(origin, (s.x, s.y)) for s in self.watch.samples()
                 if s.stamp >= float(accepted[0]["wall"]) - 0.5),
                default=0.0,
            )  # fmt: skip
        finally:
            await self.reset(intruder)
        return {
            "cancelled": float(ended[0]["wall"]) - float(accepted[0]["wall"]),
            "rolled_m": rolled,
        }

    async def fake_pose(self) -> dict[str, float]:
        intruder, go = self.intruder("--pose", "20,20")
        try:
            await self.warm(intruder)
            go.touch()
            ready = await wait(lambda: intruder_events(intruder, "intruder_ready"), 30, "ready")
            alarm = await wait(
                lambda: self.brain.first_seen.get("POSE_TOPIC_SHARED"), 30, "the alarm"
            )
        finally:
            await self.reset(intruder)
        return {"alarm": alarm - float(ready[0]["wall"])}


@contextlib.asynccontextmanager
async def rig(work: Path) -> AsyncIterator[Bench]:
    from mcp import Client

    from robot_stack_testing import (
        ProcessLauncher,
        free_tcp_port,
        fresh_token,
        mcp_transport,
        wait_for_tcp_port,
        wait_until,
    )
    from robot_stack_testing.pose_watch import AmclWatch

    token = fresh_token()
    launcher = ProcessLauncher(work)
    ready = work / "robot-sim.pid"
    watch = None
    try:
        launcher.start(
            "robot_sim",
            [sys.executable, "-m", "robot_sim"],
            env={
                "SIM_SUPERVISOR_LOCK": "true",
                "SIM_SCENES_DIR": str(work / "scenes"),
                "SIM_READY_FILE": str(ready),
                "SIM_CAMERA_FPS": "1",
            },
        )
        wait_until(ready.is_file, 60, "robot-sim ready")
        port = free_tcp_port()
        launcher.start(
            "navigation",
            [sys.executable, "-m", "robot_mcp_navigation"],
            env={
                "NAV_MOTION": "nav2",
                "MCP_TRANSPORT": "streamable-http",
                "MCP_AUTH_TOKEN": token,
                "MCP_PORT": str(port),
                "NAV_OUTBOX": str(work / "outbox.sqlite3"),
                "XDG_DATA_HOME": str(work / "xdg"),
            },
        )
        wait_for_tcp_port(port, 60)
        watch = AmclWatch()
        async with Client(mcp_transport(f"http://127.0.0.1:{port}/mcp", token)) as client:
            brain = Brain(client)
            renewing = asyncio.create_task(brain.renew_forever())
            try:
                await wait(lambda: brain.state(True, "locked"), 60, "the first lease")
                yield Bench(launcher, brain, watch, work)
            finally:
                renewing.cancel()
                with contextlib.suppress(asyncio.CancelledError):
                    await renewing
    finally:
        if watch is not None:
            watch.close()
        launcher.stop_all()


async def run(runs: int, only: list[str]) -> dict[str, Any]:
    samples: dict[str, dict[str, list[float]]] = {name: {} for name in only}
    failures: dict[str, list[str]] = {name: [] for name in only}
    with tempfile.TemporaryDirectory(prefix="intrusion-bench-") as tmp:
        async with rig(Path(tmp)) as bench:
            for name in only:
                for index in range(runs):
                    try:
                        measured = await getattr(bench, name)()
                    except (TimeoutError, AssertionError) as exc:
                        failures[name].append(str(exc))
                        print(f"{name} run {index + 1}: FAILED {exc}", flush=True)
                        continue
                    for key, value in measured.items():
                        samples[name].setdefault(key, []).append(value)
                    shown = ", ".join(f"{k}={v:.3f}" for k, v in measured.items())
                    print(f"{name} run {index + 1}: {shown}", flush=True)
    report: dict[str, Any] = {"runs": runs, "host_cpus": os.cpu_count(), "scenarios": {}}
    for name in only:
        report["scenarios"][name] = {
            key: summary(values, "m", 1.0) if key.endswith("_m") else summary(values)
            for key, values in samples[name].items()
        } | {"failures": failures[name]}
    return report


def _interrupt(*_: object) -> None:
    raise KeyboardInterrupt


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--runs", type=int, default=20)
    parser.add_argument("--only", default=",".join(SCENARIOS))
    args = parser.parse_args()
    only = [name for name in args.only.split(",") if name]
    unknown = set(only) - set(SCENARIOS)
    if unknown:
        parser.error(f"unknown scenario(s): {', '.join(sorted(unknown))}")
    os.environ.setdefault("ROS_DOMAIN_ID", str(random.randint(100, 200)))
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    signal.signal(signal.SIGTERM, _interrupt)  # stop the processes it started, also then
    report = asyncio.run(run(args.runs, only))
    RESULTS.mkdir(exist_ok=True)
    out = RESULTS / "supervision_intrusion.json"
    out.write_text(json.dumps(report, indent=2) + "\n")
    print(json.dumps(report["scenarios"], indent=2))
    print(f"wrote {out.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
