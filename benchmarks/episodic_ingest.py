"""Episodic memory: ingest CPU and storage per robot-hour, measured on the real server process.

A publisher in this process sends what a busy robot sends: 4 skills x 10 Hz
``detections_meta`` (3 detections each, labels changing now and then) and the pose at 10 Hz
(driving between the map's places), over ROS on loopback, to a real ``robot-mcp-episodic``
(sse). CPU = the server's user+system time over the measured window (start-up excluded);
storage = index and MCAP bytes written in the window, scaled to one hour.

Baseline in the same window: a bare rclpy process subscribing raw to the same topics through
the same bridge (``_episodic_bare_subscriber.py``). The machine is shared, so its CPU moves
with the load as the server's does; server minus baseline is what the episodic work costs.
``--runs N`` repeats the whole measurement (fresh processes) and reports every run and the
range.

    uv run python benchmarks/episodic_ingest.py [--seconds 60] [--runs 3]
        # writes benchmarks/results/episodic_ingest.json
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import sys
import tempfile
import time
import uuid
from pathlib import Path
from typing import Any

from robot_mcp_episodic.store.sqlite import SqliteEpisodicStore
from robot_ros_bridge import RosBridge
from robot_stack_testing import (
    ProcessLauncher,
    free_tcp_port,
    fresh_token,
    wait_for_tcp_port,
)

TOKEN = fresh_token()  # the servers' MCP_AUTH_TOKEN
RESULTS = Path(__file__).parent / "results"
SKILLS = ("detect", "people", "find_mug", "doors")
LABELS = ("mug", "chair", "person", "laptop", "door", "plant", "bottle", "bag", "monitor")
BARE_EXECUTORS = ("multi_threaded", "single_threaded")
ROUTE = ((0.0, 0.0), (9.0, -3.0), (4.0, 1.5), (11.0, 10.0), (17.0, 3.0))


def cpu_seconds(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def thread_cpu(pid: int) -> dict[str, float]:
    """CPU seconds per thread name of ``pid`` (where the time goes)."""
    found: dict[str, float] = {}
    for task in Path(f"/proc/{pid}/task").iterdir():
        try:
            name = (task / "comm").read_text().strip()
            fields = (task / "stat").read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        used = (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
        found[name] = found.get(name, 0.0) + used
    return found


def dir_bytes(path: Path) -> int:
    return sum(f.stat().st_size for f in path.rglob("*") if f.is_file())


def measure_once(seconds: float, idle: bool) -> dict[str, Any]:
    from geometry_msgs.msg import PoseWithCovarianceStamped
    from ros2_vision_interfaces.msg import VisionDetection, VisionDetectionArray

    work = Path(tempfile.mkdtemp(prefix="episodic-bench-"))
    launcher = ProcessLauncher(work)
    port = free_tcp_port()
    pose_topic = f"/bench_pose_{uuid.uuid4().hex[:6]}"
    server = launcher.start(
        "episodic", [sys.executable, "-m", "robot_mcp_episodic"],
        env={"MCP_TRANSPORT": "sse", "MCP_AUTH_TOKEN": TOKEN, "MCP_PORT": str(port),
             "EPISODIC_DIR": str(work / "data"), "EPISODIC_POSE_TOPIC": pose_topic,
             "LOG_LEVEL": "WARNING"},
    )  # fmt: skip
    bares = {
        kind: launcher.start(
            f"bare_{kind}",
            [
                sys.executable,
                str(Path(__file__).parent / "_episodic_bare_subscriber.py"),
                kind,
                pose_topic,
                *SKILLS,
            ],
        )
        for kind in BARE_EXECUTORS
    }
    try:
        wait_for_tcp_port(port, 60.0)
        with RosBridge("episodic_bench_publisher") as bridge:
            metas = {
                s: bridge.create_publisher(VisionDetectionArray, f"/vision/{s}/detections_meta")
                for s in SKILLS
            }
            pose_pub = bridge.create_publisher(PoseWithCovarianceStamped, pose_topic)
            deadline = time.monotonic() + 30.0
            topics = [pose_topic, *(f"/vision/{s}/detections_meta" for s in SKILLS)]
            while time.monotonic() < deadline:  # the server subscribes on its graph poll
                if all(bridge.node.count_subscribers(t) >= 1 + len(bares) for t in topics):
                    break
                time.sleep(0.1)
            else:
                raise TimeoutError("the server and the baseline did not subscribe within 30 s")
            sent = 0
            tick = 0

            def publish_tick(now: float) -> None:
                nonlocal sent, tick
                leg = (tick // 200) % (len(ROUTE) - 1)
                frac = (tick % 200) / 200
                (x0, y0), (x1, y1) = ROUTE[leg], ROUTE[leg + 1]
                pose = PoseWithCovarianceStamped()
                pose.header.stamp.sec, pose.header.stamp.nanosec = int(now), int(now % 1 * 1e9)
                pose.pose.pose.position.x = x0 + (x1 - x0) * frac
                pose.pose.pose.position.y = y0 + (y1 - y0) * frac
                yaw = math.atan2(y1 - y0, x1 - x0)
                pose.pose.pose.orientation.z, pose.pose.pose.orientation.w = (
                    math.sin(yaw / 2),
                    math.cos(yaw / 2),
                )
                pose_pub.publish(pose)
                for index, skill in enumerate(SKILLS):
                    msg = VisionDetectionArray()
                    msg.header.stamp = pose.header.stamp
                    msg.skill = skill
                    for k in range(3):
                        det = VisionDetection()
                        det.label = LABELS[(index + k + tick // 150) % len(LABELS)]
                        det.score = 0.6 + 0.3 * math.sin(tick / 7 + k)
                        det.box.x_offset, det.box.width, det.box.height = 10 * k, 80, 60
                        msg.detections.append(det)
                    metas[skill].publish(msg)
                sent += 1 + len(SKILLS)
                tick += 1

            warm_end = time.monotonic() + 5.0
            next_at = time.monotonic()
            measuring = False
            cpu0 = wall0 = 0.0
            bare0 = dict.fromkeys(bares, 0.0)
            bytes0 = 0
            load0 = os.getloadavg()
            end = warm_end + seconds
            while time.monotonic() < end:
                if not measuring and time.monotonic() >= warm_end:
                    measuring, sent = True, 0
                    cpu0, wall0 = cpu_seconds(server.pid), time.monotonic()
                    bare0 = {kind: cpu_seconds(p.pid) for kind, p in bares.items()}
                    bytes0 = dir_bytes(work / "data")
                    load0 = os.getloadavg()
                if not idle:
                    publish_tick(time.time())
                next_at += 0.1
                time.sleep(max(0.0, next_at - time.monotonic()))
            cpu = cpu_seconds(server.pid) - cpu0
            bare_cpu = {kind: cpu_seconds(p.pid) - bare0[kind] for kind, p in bares.items()}
            threads = thread_cpu(server.pid)
            wall = time.monotonic() - wall0
            load1 = os.getloadavg()
        time.sleep(1.5)  # one more flush interval
    finally:
        launcher.stop_all()  # a clean stop: the WAL is merged, the open bag finished
    data = work / "data"
    empty = SqliteEpisodicStore(work / "empty.sqlite3", "robot-1")
    empty.close()
    index_bytes = (data / "episodic.sqlite3").stat().st_size
    index_bytes -= (work / "empty.sqlite3").stat().st_size
    bag_bytes = dir_bytes(data / "bags")
    grown = dir_bytes(data) - bytes0
    scale = 3600.0 / wall
    server_pct = 100 * cpu / wall
    bare_pct = {kind: round(100 * used / wall, 2) for kind, used in bare_cpu.items()}
    return {
        "seconds": round(wall, 1),
        "messages_sent": sent,
        "rate_msgs_per_s": round(sent / wall, 1),
        "cpu_percent_of_one_core": round(server_pct, 2),
        "bare_subscriber_cpu_percent": bare_pct,
        "server_minus_bare_percent": {
            kind: round(server_pct - used, 2) for kind, used in bare_pct.items()
        },
        "index_mb_per_hour": round(index_bytes * scale / 1e6, 2),
        "mcap_mb_per_hour": round(bag_bytes * scale / 1e6, 1),
        "growth_mb_per_hour": round(grown * scale / 1e6, 1),
        "load_average_start": [round(x, 2) for x in load0],
        "load_average_end": [round(x, 2) for x in load1],
        "cpu_s_by_thread_incl_startup": {k: round(v, 2) for k, v in threads.items()},
    }


def spread(values: list[float]) -> dict[str, float]:
    return {"min": min(values), "median": round(statistics.median(values), 2), "max": max(values)}


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--seconds", type=float, default=60.0)
    parser.add_argument("--runs", type=int, default=1)
    parser.add_argument("--idle", action="store_true", help="publish nothing: the idle server")
    args = parser.parse_args()
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    os.environ.setdefault("ROS_DOMAIN_ID", str(40 + os.getpid() % 50))
    runs = []
    for number in range(args.runs):
        run = measure_once(args.seconds, args.idle)
        runs.append(run)
        print(
            f"run {number + 1}: {run['rate_msgs_per_s']} msg/s for {run['seconds']} s, load "
            f"{run['load_average_start'][0]}->{run['load_average_end'][0]}: server "
            f"{run['cpu_percent_of_one_core']} %, bare rclpy subscriber "
            f"{run['bare_subscriber_cpu_percent']} %, difference "
            f"{run['server_minus_bare_percent']} %"
        )
    result = {
        "runs": runs,
        "cpu_percent_of_one_core": spread([r["cpu_percent_of_one_core"] for r in runs]),
        "bare_subscriber_cpu_percent": {
            kind: spread([r["bare_subscriber_cpu_percent"][kind] for r in runs])
            for kind in BARE_EXECUTORS
        },
        "server_minus_bare_percent": {
            kind: spread([r["server_minus_bare_percent"][kind] for r in runs])
            for kind in BARE_EXECUTORS
        },
        "index_mb_per_hour": spread([r["index_mb_per_hour"] for r in runs]),
        "mcap_mb_per_hour": spread([r["mcap_mb_per_hour"] for r in runs]),
        "idle": args.idle,
        "index_hz": os.environ.get("EPISODIC_INDEX_HZ", "2"),
        "note": "index (after a clean stop, minus an empty index) and MCAP bytes include the "
        "5 s warm-up; scaled linearly to one hour. The bare subscriber is a raw rclpy "
        "subscriber to the same 5 topics through the same RosBridge (with either executor), "
        "measured in the same window: the floor rclpy + DDS cost on this machine at this load.",
    }
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / "episodic_ingest.json").write_text(json.dumps(result, indent=2))
    print(
        f"server CPU {result['cpu_percent_of_one_core']} % of one core (goal < 5 %); bare "
        f"subscriber {result['bare_subscriber_cpu_percent']} %; difference "
        f"{result['server_minus_bare_percent']} %; index {result['index_mb_per_hour']} MB/h "
        f"(goal <= 5), MCAP {result['mcap_mb_per_hour']} MB/h"
    )


if __name__ == "__main__":
    main()
