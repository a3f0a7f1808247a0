"""Benchmark: the navigation server with NAV_MOTION=nav2 against a real rclpy NavigateToPose
server in another process (robot_stack_testing.navigation.nav2_server --trace), over ROS on
loopback, events posted signed to a local receiver (the brain's place).

Per round: navigate_to → a few feedback messages → stop_navigation. Reports p50/p99 of
- navigate_to (MCP call sent) → goal received by the action server (its goal callback),
- action feedback published → the matching `progress` event verified at the receiver,
- stop_navigation (MCP call sent) → goal CANCELED at the action server (goal < 100 ms),
and the navigate_to / stop_navigation round trips. Times cross processes on one host's wall
clock. Writes benchmarks/results/navigation_nav2.json.

    uv run python benchmarks/navigation_nav2.py [--rounds 30]
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import random
import re
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from mcp import Client
from mcp_types import CallToolResult, TextContent

from robot_stack_testing import fresh_token, mcp_transport
from robot_stack_testing.navigation.receiver import EventReceiver, running_receiver

TOKEN = fresh_token()  # the servers' MCP_AUTH_TOKEN
SECRET = "benchmark-secret"
RESULTS = Path(__file__).parent / "results" / "navigation_nav2.json"
TRACE = re.compile(r"^trace (\w+)(?: nav_time=([\d.]+))? wall=([\d.]+)$")
PLACES = ["kitchen", "reception", "desk_alice", "meeting_room"]


def free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        port: int = sock.getsockname()[1]
        return port


def percentile(values: list[float], q: float) -> float:
    if not values:
        return float("nan")
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, round(q * (len(ordered) - 1)))]


def summary(values_s: list[float]) -> dict[str, float]:
    ms = [v * 1000 for v in values_s]
    return {
        "n": len(ms),
        "p50_ms": round(percentile(ms, 0.5), 2),
        "p99_ms": round(percentile(ms, 0.99), 2),
        "max_ms": round(max(ms), 2) if ms else float("nan"),
    }


def answer(result: CallToolResult) -> dict[str, Any]:
    (content,) = result.content
    assert isinstance(content, TextContent)
    if result.is_error:
        raise RuntimeError(content.text)
    value: dict[str, Any] = json.loads(content.text)
    return value


def traces(log: Path) -> list[tuple[str, float | None, float]]:
    out = []
    for line in log.read_text(errors="replace").splitlines():
        match = TRACE.match(line.strip())
        if match:
            nav_time = float(match[2]) if match[2] else None
            out.append((match[1], nav_time, float(match[3])))
    return out


async def wait_for(check: Any, timeout_s: float, what: str) -> None:
    deadline = time.monotonic() + timeout_s
    while not check():
        if time.monotonic() > deadline:
            raise TimeoutError(f"timed out waiting for {what}")
        await asyncio.sleep(0.005)


async def run_rounds(port: int, receiver: EventReceiver, rounds: int) -> dict[str, Any]:
    sent: list[float] = []
    stops: list[float] = []
    nav_rtt: list[float] = []
    stop_rtt: list[float] = []
    tasks: list[str] = []
    async with Client(mcp_transport(f"http://127.0.0.1:{port}/mcp", TOKEN)) as client:
        # Nav2 discovery and the first goal are not what is measured: one warm-up round.
        for index in range(rounds + 1):
            place = PLACES[index % len(PLACES)]
            started = time.time()
            info = answer(await client.call_tool("navigate_to", {"location": place}))
            nav_done = time.time()
            task_id = info["task_id"]
            await wait_for(
                lambda t=task_id: receiver.types(t).count("progress") >= 3, 10, "progress"
            )
            stop_started = time.time()
            answer(await client.call_tool("stop_navigation", {}))
            stop_done = time.time()
            if index == 0:
                continue
            sent.append(started)
            stops.append(stop_started)
            nav_rtt.append(nav_done - started)
            stop_rtt.append(stop_done - stop_started)
            tasks.append(task_id)
    return {"sent": sent, "stops": stops, "nav_rtt": nav_rtt, "stop_rtt": stop_rtt, "tasks": tasks}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=30)
    args = parser.parse_args()
    env = {
        **os.environ,
        "ROS_DOMAIN_ID": str(random.SystemRandom().randint(150, 200)),
        "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST",
        "PYTHONUNBUFFERED": "1",
    }
    with tempfile.TemporaryDirectory() as tmp, running_receiver(free_port(), SECRET) as receiver:
        nav2_log, nav_log = Path(tmp) / "nav2.log", Path(tmp) / "navigation.log"
        port = free_port()
        processes: list[subprocess.Popen[bytes]] = []
        try:
            with nav2_log.open("wb") as out:
                processes.append(
                    subprocess.Popen(
                        [
                            sys.executable,
                            "-m",
                            "robot_stack_testing.navigation.nav2_server",
                            "--speed",
                            "0.3",
                            "--trace",
                        ],
                        env=env,
                        stdout=out,
                        stderr=subprocess.STDOUT,
                    )
                )
            with nav_log.open("wb") as out:
                processes.append(
                    subprocess.Popen(
                        [sys.executable, "-m", "robot_mcp_navigation"],
                        env={
                            **env,
                            "NAV_MOTION": "nav2",
                            "NAV_SUPERVISION": "off",  # no brain: nobody holds a lease
                            "MCP_TRANSPORT": "streamable-http",
                            "MCP_AUTH_TOKEN": TOKEN,
                            "MCP_PORT": str(port),
                            "RVC_EVENTS_URL": receiver.url,
                            "RVC_EVENT_SECRET": SECRET,
                            "NAV_OUTBOX": str(Path(tmp) / "outbox.sqlite3"),
                            "NAV_PROGRESS_INTERVAL_S": "0.01",  # every feedback → progress
                            "NAV2_SERVER_TIMEOUT_S": "20",
                            "LOG_LEVEL": "WARNING",
                        },
                        stdout=out,
                        stderr=subprocess.STDOUT,
                    )
                )
            deadline = time.monotonic() + 30
            while time.monotonic() < deadline:
                try:
                    socket.create_connection(("127.0.0.1", port), timeout=0.2).close()
                    break
                except OSError:
                    time.sleep(0.1)
            run = asyncio.run(run_rounds(port, receiver, args.rounds))
        finally:
            for process in reversed(processes):
                process.terminate()
                try:
                    process.wait(timeout=10)
                except subprocess.TimeoutExpired:
                    process.kill()
        trace = traces(nav2_log)

    received = [wall for what, _, wall in trace if what == "goal_received"][1:]  # warm-up
    canceled = [wall for what, _, wall in trace if what == "goal_canceled"][1:]
    accept = [r - s for s, r in zip(run["sent"], received, strict=True)]
    cancel = [c - s for s, c in zip(run["stops"], canceled, strict=True)]
    # feedback → progress: the round's feedback with the event's navigation time
    goal_starts = [wall for what, _, wall in trace if what == "goal_received"]
    feedback_latency: list[float] = []
    feedbacks = [(t, wall) for what, t, wall in trace if what == "feedback"]
    for round_index, task_id in enumerate(run["tasks"], start=1):
        start = goal_starts[round_index]
        end = goal_starts[round_index + 1] if round_index + 1 < len(goal_starts) else float("inf")
        published = {t: wall for t, wall in feedbacks if start <= wall < end}
        for event in receiver.unique(task_id):
            if event.type != "progress":
                continue
            wall = published.get(round(float(event.payload["elapsed_s"]), 2))
            if wall is not None:
                feedback_latency.append(receiver.arrivals[event.event_id] - wall)

    result = {
        "benchmark": "navigation_nav2",
        "rounds": args.rounds,
        "navigate_to_to_goal_received": summary(accept),
        "feedback_to_progress_event": summary(feedback_latency),
        "stop_navigation_to_goal_canceled": summary(cancel),
        "navigate_to_round_trip": summary(run["nav_rtt"]),
        "stop_navigation_round_trip": summary(run["stop_rtt"]),
        "signature_rejections": len(receiver.rejected),
        "goal_ms": {"stop_navigation_to_goal_canceled_p99": 100},
    }
    RESULTS.parent.mkdir(parents=True, exist_ok=True)
    RESULTS.write_text(json.dumps(result, indent=2) + "\n")
    for key in (
        "navigate_to_to_goal_received",
        "feedback_to_progress_event",
        "stop_navigation_to_goal_canceled",
        "navigate_to_round_trip",
        "stop_navigation_round_trip",
    ):
        s = result[key]
        print(f"{key:36s} n={s['n']:4d} p50={s['p50_ms']:8.2f} ms p99={s['p99_ms']:8.2f} ms")
    print(f"wrote {RESULTS}")


if __name__ == "__main__":
    main()
