"""Benchmark: the manipulation server (its rclpy adapter, in this process) against a robot-sim
process over ROS on loopback, the robot standing in the mailroom.

Per round: a detection result is published as the vision node does, then
- pick (MCP call sent) → the goal received by robot-sim's Pick action server, the pick runs
  to the end (the package is held);
- place (MCP call sent) → the goal received by the Place action server (the package goes back);
- a second pick, and stop_manipulation (MCP call sent) once it is running → the goal CANCELED
  at the action server (goal: p99 < 100 ms).
The action server's moments are robot-sim's log lines (`manipulation_goal_received`,
`pick_canceled`, ISO timestamps); both processes read one host's wall clock. Writes
benchmarks/results/manipulation.json.

    uv run python benchmarks/manipulation.py [--rounds 20]
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import random
import subprocess
import sys
import tempfile
import time
from datetime import datetime
from pathlib import Path
from typing import Any

from mcp import Client

from robot_stack_testing import async_wait_until

RESULTS = Path(__file__).parent / "results" / "manipulation.json"
TOPIC = "/vision/find_object/detections"


def percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return (
        ordered[min(len(ordered) - 1, round(q * (len(ordered) - 1)))] if ordered else float("nan")
    )


def summary(values_s: list[float]) -> dict[str, float]:
    ms = [v * 1000 for v in values_s]
    return {
        "n": len(ms),
        "p50_ms": round(percentile(ms, 0.5), 2),
        "p99_ms": round(percentile(ms, 0.99), 2),
        "max_ms": round(max(ms), 2) if ms else float("nan"),
    }


class SimLog:
    """robot-sim's JSON log lines (stderr), read as they come."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.offset = 0
        self.lines: list[dict[str, Any]] = []

    def read(self) -> None:
        with self.path.open() as f:
            f.seek(self.offset)
            for line in f:
                if line.startswith("{"):
                    self.lines.append(json.loads(line))
            self.offset = f.tell()

    async def when(self, event: str, after: float, timeout_s: float = 20.0) -> float:
        """Wall time (epoch s) of the first ``event`` logged after ``after``."""
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            self.read()
            for line in self.lines:
                if line.get("event") == event:
                    at = datetime.fromisoformat(line["timestamp"].replace("Z", "+00:00"))
                    if at.timestamp() >= after:
                        return at.timestamp()
            await asyncio.sleep(0.01)
        raise TimeoutError(f"robot-sim logged no {event}")


async def answer(client: Client, tool: str, args: dict[str, Any] | None = None) -> Any:
    result = await client.call_tool(tool, args or {})
    data = json.loads(result.content[0].text)  # type: ignore[union-attr]
    if result.is_error:
        raise RuntimeError(f"{tool}: {data}")
    return data


async def finished(client: Client, task_id: str, timeout_s: float = 30.0) -> dict[str, Any]:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        info: dict[str, Any] = await answer(client, "get_task", {"task_id": task_id})
        if info["state"] != "running":
            return info
        await asyncio.sleep(0.02)
    raise TimeoutError(task_id)


async def run(rounds: int, log: SimLog) -> dict[str, Any]:
    from nav2_msgs.action import NavigateToPose
    from ros2_vision_interfaces.msg import VisionDetection, VisionDetectionArray

    from robot_mcp_manipulation.composition import build_app
    from robot_mcp_manipulation.config import load_settings
    from robot_ros_bridge import RosBridge
    from robot_sim.manipulation_server import RESULT_QOS

    work = Path(tempfile.mkdtemp(prefix="bench-manip-"))
    # no brain here to hold a lease: the arm runs unsupervised (MANIP_SUPERVISION=off)
    app = build_app(
        load_settings({"MANIP_OUTBOX": str(work / "outbox.sqlite3"), "MANIP_SUPERVISION": "off"})
    )
    bridge = RosBridge("manipulation_bench").start()
    pub = bridge.create_publisher(VisionDetectionArray, TOPIC, RESULT_QOS)
    nav = bridge.create_action_client(NavigateToPose, "/navigate_to_pose")
    goal = NavigateToPose.Goal()
    goal.pose.header.frame_id = "map"
    goal.pose.pose.position.x, goal.pose.pose.position.y = 17.0, 3.0  # the mailroom
    goal.pose.pose.orientation.w = 1.0
    await bridge.wait_for_server(nav, 20.0)
    handle = await bridge.await_future(nav.send_goal_async(goal), 10.0)
    await bridge.await_future(handle.get_result_async(), 120.0)

    def seen() -> dict[str, Any]:
        msg = VisionDetectionArray(skill="find_object")
        msg.header.stamp = bridge.node.get_clock().now().to_msg()
        msg.detections = [VisionDetection(label="yellow package", score=0.9)]
        pub.publish(msg)
        return {"topic": TOPIC, "stamp": msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9}

    pick_goal: list[float] = []
    place_goal: list[float] = []
    stop_cancel: list[float] = []
    pick_round_trip: list[float] = []
    try:
        async with app.running(), Client(app.server) as client:
            await async_wait_until(
                lambda: bridge.node.count_subscribers(TOPIC) > 0, 20, "robot-sim on the topic"
            )
            for n in range(rounds + 2):
                warmup = n < 2
                ref = seen()
                await asyncio.sleep(0.2)  # the result reaches robot-sim before the goal does
                pick_sent, started = time.time(), time.monotonic()
                info = await answer(client, "pick", {"label": "package", "mask_ref": ref})
                returned = time.monotonic() - started
                picked = await log.when("manipulation_goal_received", pick_sent)
                done = await finished(client, info["task_id"])
                assert done["state"] == "succeeded", done
                place_sent = time.time()
                info = await answer(client, "place")
                placed = await log.when("manipulation_goal_received", place_sent)
                assert (await finished(client, info["task_id"]))["state"] == "succeeded"
                ref = seen()
                await asyncio.sleep(0.2)
                info = await answer(client, "pick", {"label": "package", "mask_ref": ref})
                await async_wait_until(
                    lambda tid=info["task_id"]: (
                        app.manipulator.get_task(tid).model_dump().get("progress")
                    ),
                    20,
                    "the pick running",
                    0.005,
                )
                await asyncio.sleep(random.uniform(0.0, 0.3))  # somewhere in the pick
                stop_sent = time.time()
                await answer(client, "stop_manipulation")
                cancelled = await log.when("pick_canceled", stop_sent)
                if not warmup:
                    pick_goal.append(picked - pick_sent)
                    place_goal.append(placed - place_sent)
                    stop_cancel.append(cancelled - stop_sent)
                    pick_round_trip.append(returned)
                print(f"round {n}: done", file=sys.stderr)
    finally:
        bridge.close()
        for close in app.closers:
            close()
    return {
        "pick_call_to_goal": summary(pick_goal),
        "place_call_to_goal": summary(place_goal),
        "stop_to_pick_canceled": summary(stop_cancel),
        "pick_tool_round_trip": summary(pick_round_trip),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=20)
    args = parser.parse_args()
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    os.environ.setdefault("ROS_DOMAIN_ID", str(random.randint(120, 200)))
    work = Path(tempfile.mkdtemp(prefix="bench-sim-"))
    ready, log_path = work / "ready", work / "robot-sim.log"
    env = {
        **os.environ,
        "SIM_SCENES_DIR": str(work / "scenes"),
        "SIM_TIME_SCALE": "20",
        "SIM_FAILURES": "off",
        "SIM_PICK_S": "20",  # 1 s of wall time: room to stop a pick mid-way
        "SIM_PLACE_S": "4",
        "SIM_READY_FILE": str(ready),
    }
    with log_path.open("w") as log_file:
        sim = subprocess.Popen(
            [sys.executable, "-m", "robot_sim"], env=env, stderr=log_file, stdout=log_file
        )
    try:
        deadline = time.monotonic() + 60
        while not ready.exists():
            if time.monotonic() > deadline or sim.poll() is not None:
                raise SystemExit(f"robot-sim did not start: {log_path.read_text()[-2000:]}")
            time.sleep(0.1)
        load = os.getloadavg()
        results = asyncio.run(run(args.rounds, SimLog(log_path)))
    finally:
        sim.terminate()
        sim.wait(10)
    report = {
        "benchmark": "manipulation",
        "rounds": args.rounds,
        "load_average_at_start": [round(v, 2) for v in load],
        "measured_at": datetime.now().isoformat(timespec="seconds"),
        **results,
    }
    RESULTS.parent.mkdir(parents=True, exist_ok=True)
    RESULTS.write_text(json.dumps(report, indent=2) + "\n")
    for name, value in results.items():
        p50, p99 = value["p50_ms"], value["p99_ms"]
        print(f"{name:26} p50 {p50:8.2f} ms   p99 {p99:8.2f} ms   (n={value['n']})")
    print(f"load average at start {load[0]:.1f}; JSON: {RESULTS}")


if __name__ == "__main__":
    main()
