"""Benchmark: the perception buffer process under 50 skills x 10 Hz.

A fake vision node (real rclpy, separate process) runs ``--skills`` skills, each publishing
``detections_meta`` + one boolean output at ``--hz``. The buffer server (separate process,
streamable-http) follows them all. Its CPU % and RSS are sampled from /proc every
``--sample-s`` for ``--seconds`` (60 s default; ``--minutes 5`` for the long run); the check
is that both stay bounded (RSS growth over the second half of the run, CPU trend).

    uv run python benchmarks/bridges_buffer_load.py [--skills 50] [--hz 10] [--seconds 60]

Writes benchmarks/results/bridges_buffer_load.json.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import platform
import random
import statistics
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from mcp import Client

from robot_ros_bridge import RosBridge
from robot_ros_bridge.vision_tasks import RosVisionTasks
from robot_stack_testing import (
    ProcessLauncher,
    free_tcp_port,
    fresh_token,
    mcp_transport,
    wait_for_tcp_port,
)

TOKEN = fresh_token()  # the servers' MCP_AUTH_TOKEN
RESULTS = Path(__file__).parent / "results" / "bridges_buffer_load.json"
TICK = os.sysconf("SC_CLK_TCK")
PAGE = os.sysconf("SC_PAGE_SIZE")


def cpu_ticks(pid: int) -> int:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return int(fields[11]) + int(fields[12])  # utime + stime


def rss_mb(pid: int) -> float:
    return int(Path(f"/proc/{pid}/statm").read_text().split()[1]) * PAGE / 1e6


async def create_skills(node: str, count: int) -> None:
    with RosBridge(f"bench_loader_{os.getpid()}") as bridge:
        tasks = RosVisionTasks(bridge, node, timeout_s=10.0, wait_for_service_s=10.0)
        for i in range(count):
            await tasks.create(
                {
                    "name": f"load_{i:02d}",
                    "mode": "describe",
                    "outputs": [{"name": "seen", "type": "boolean"}],
                }
            )


async def buffer_state(url: str) -> dict[str, Any]:
    async with Client(mcp_transport(url, TOKEN)) as client:
        result = await client.call_tool("list_buffers", {})
        data = json.loads(result.content[0].text)  # type: ignore[union-attr]
        t0 = time.perf_counter()
        await client.call_tool("what_do_you_see", {})
        wdys_ms = (time.perf_counter() - t0) * 1000
    return {
        "following": len(data["following"]),
        "max_results_per_skill": max((b["results"] for b in data["buffers"]), default=0),
        "what_do_you_see_ms": round(wdys_ms, 2),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--skills", type=int, default=50)
    parser.add_argument("--hz", type=float, default=10.0)
    parser.add_argument("--seconds", type=float, default=60.0)
    parser.add_argument("--minutes", type=float, default=None, help="overrides --seconds")
    parser.add_argument("--sample-s", type=float, default=5.0)
    args = parser.parse_args()
    duration = args.minutes * 60 if args.minutes else args.seconds
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    os.environ["ROS_DOMAIN_ID"] = str(random.SystemRandom().randint(60, 99))
    node = f"load_vision_{os.getpid()}"
    launcher = ProcessLauncher(Path(tempfile.mkdtemp(prefix="buffer-load-")))
    samples: list[dict[str, float]] = []
    loadavg_start = Path("/proc/loadavg").read_text().split()[:3]
    try:
        launcher.start(
            "vision",
            [
                sys.executable,
                "-m",
                "robot_stack_testing.ros.fake_vision",
                "--name",
                node,
                "--hz",
                str(args.hz),
            ],
        )
        asyncio.run(create_skills(node, args.skills))
        port = free_tcp_port()
        buffer = launcher.start(
            "perception",
            [sys.executable, "-m", "mcp_perception_buffer"],
            env={
                "MCP_TRANSPORT": "streamable-http",
                "MCP_AUTH_TOKEN": TOKEN,
                "MCP_PORT": str(port),
                "VISION_NODE_NAME": node,
                "LOG_LEVEL": "WARNING",
            },
        )
        wait_for_tcp_port(port, 30.0)
        url = f"http://127.0.0.1:{port}/mcp"
        time.sleep(5.0)  # discovery + subscriptions
        start_state = asyncio.run(buffer_state(url))
        started = time.monotonic()
        last_ticks, last_t = cpu_ticks(buffer.pid), time.monotonic()
        while time.monotonic() - started < duration:
            time.sleep(args.sample_s)
            ticks, now = cpu_ticks(buffer.pid), time.monotonic()
            samples.append(
                {
                    "t_s": round(now - started, 1),
                    "cpu_pct": round(100 * (ticks - last_ticks) / TICK / (now - last_t), 1),
                    "rss_mb": round(rss_mb(buffer.pid), 1),
                }
            )
            last_ticks, last_t = ticks, now
        end_state = asyncio.run(buffer_state(url))
        loadavg_end = Path("/proc/loadavg").read_text().split()[:3]
    finally:
        launcher.stop_all()
    half = samples[len(samples) // 2 :]
    cpu = [s["cpu_pct"] for s in samples]
    report = {
        "benchmark": "bridges_buffer_load",
        "skills": args.skills,
        "publish_hz_per_skill": args.hz,
        "messages_per_s": args.skills * args.hz * 2,
        "duration_s": duration,
        "machine": {"python": platform.python_version(), "cpus": os.cpu_count()},
        "loadavg": {"start": loadavg_start, "end": loadavg_end},
        "ts": time.time(),
        "cpu_pct": {
            "mean": round(statistics.mean(cpu), 1),
            "max": max(cpu),
            "first": cpu[0],
            "last": cpu[-1],
        },
        "rss_mb": {
            "first": samples[0]["rss_mb"],
            "last": samples[-1]["rss_mb"],
            "max": max(s["rss_mb"] for s in samples),
            "growth_second_half": round(half[-1]["rss_mb"] - half[0]["rss_mb"], 1),
        },
        "buffer_at_start": start_state,
        "buffer_at_end": end_state,
        "samples": samples,
    }
    RESULTS.parent.mkdir(parents=True, exist_ok=True)
    RESULTS.write_text(json.dumps(report, indent=2) + "\n", encoding="utf-8")
    print(json.dumps({k: v for k, v in report.items() if k != "samples"}, indent=2))


if __name__ == "__main__":
    main()
