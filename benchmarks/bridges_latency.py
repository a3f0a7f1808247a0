"""Benchmark: the MCP bridges over a real transport (streamable-http on 127.0.0.1).

1. ``instantiate_skill`` (skill_control) -> first result visible through ``get_latest``
   (perception buffer), p50/p90 over N skills.
2. ``get_latest`` round trip over MCP, p50/p90.

Both servers run as OS processes; the vision side is the fake vision node (real rclpy,
auto-publishing every skill at ``--hz``) unless ``--vision real`` starts
``robot_mcp_perception.vision_node`` with its offline defaults. Loopback discovery and a
domain id of its own; every process is stopped by PID.

    uv run python benchmarks/bridges_latency.py [--skills 10] [--calls 200] [--vision fake|real]

Writes benchmarks/results/bridges_latency.json (fake) or bridges_latency_real.json (real).
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

from robot_stack_testing import (
    ProcessLauncher,
    free_tcp_port,
    fresh_token,
    mcp_transport,
    wait_for_tcp_port,
)

TOKEN = fresh_token()  # the servers' MCP_AUTH_TOKEN
RESULTS_DIR = Path(__file__).parent / "results"
REPO = Path(__file__).resolve().parents[1]


def pct(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return round(ordered[min(len(ordered) - 1, int(q * len(ordered)))] * 1000, 2)


async def call(client: Client, tool: str, args: dict[str, Any]) -> tuple[bool, Any]:
    result = await client.call_tool(tool, args)
    return bool(result.is_error), json.loads(result.content[0].text)  # type: ignore[union-attr]


async def measure(urls: tuple[str, str], skills: int, calls: int) -> dict[str, Any]:
    first_result: list[float] = []
    round_trips: list[float] = []
    async with (
        Client(mcp_transport(urls[0], TOKEN)) as control,
        Client(mcp_transport(urls[1], TOKEN)) as perception,
    ):
        for i in range(skills):
            started = time.perf_counter()
            wall = time.time()
            error, made = await call(
                control,
                "instantiate_skill",
                {"template": "find_object", "params": {"query": f"red mug {i}"}},
            )
            if error:
                raise RuntimeError(f"instantiate_skill failed: {made}")
            deadline = time.monotonic() + 30
            while time.monotonic() < deadline:
                error, latest = await call(perception, "get_latest", {"skill": made["skill_id"]})
                # a result of a frame taken after the call; with the real node and its
                # annotation grounder a frame without the object is a result with no detections
                stamp = None if error else latest.get("detections_stamp")
                if stamp is not None and stamp >= wall:
                    break
                await asyncio.sleep(0.01)
            else:
                raise RuntimeError(f"no result for {made['skill_id']} in 30 s")
            first_result.append(time.perf_counter() - started)
            if i == 0:
                for _ in range(calls):
                    t0 = time.perf_counter()
                    await call(perception, "get_latest", {"skill": made["skill_id"]})
                    round_trips.append(time.perf_counter() - t0)
            await call(control, "stop_skill", {"skill_id": made["skill_id"]})
    return {
        "instantiate_to_first_result_ms": {
            "n": len(first_result),
            "p50": pct(first_result, 0.5),
            "p90": pct(first_result, 0.9),
            "mean": round(statistics.mean(first_result) * 1000, 2),
        },
        "get_latest_round_trip_ms": {
            "n": len(round_trips),
            "p50": pct(round_trips, 0.5),
            "p90": pct(round_trips, 0.9),
            "mean": round(statistics.mean(round_trips) * 1000, 2),
        },
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--skills", type=int, default=10)
    parser.add_argument("--calls", type=int, default=200)
    parser.add_argument("--hz", type=float, default=10.0)
    parser.add_argument("--vision", choices=["fake", "real"], default="fake")
    args = parser.parse_args()
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    os.environ["ROS_DOMAIN_ID"] = str(random.SystemRandom().randint(60, 99))
    node = f"bench_vision_{os.getpid()}"
    loadavg_start = Path("/proc/loadavg").read_text().split()[:3]
    launcher = ProcessLauncher(Path(tempfile.mkdtemp(prefix="bridges-bench-")))
    try:
        if args.vision == "fake":
            argv = [
                sys.executable,
                "-m",
                "robot_stack_testing.ros.fake_vision",
                "--name",
                node,
                "--hz",
                str(args.hz),
            ]
            launcher.start("vision", argv)
        else:
            launcher.start(
                "vision",
                [sys.executable, "-m", "robot_mcp_perception.vision_node"],
                env={
                    "PERCEPTION_CONFIG_OVERRIDES": (
                        f"artifacts.port={free_tcp_port()} node.node_name={node}"
                    ),
                    "PERCEPTION_FRAMES_DIR": str(REPO / "data" / "scenes"),
                },
            )
        ports = free_tcp_port(), free_tcp_port()
        common = {
            "MCP_TRANSPORT": "streamable-http",
            "MCP_AUTH_TOKEN": TOKEN,
            "VISION_NODE_NAME": node,
            "LOG_LEVEL": "WARNING",
        }
        launcher.start(
            "skill-control",
            [sys.executable, "-m", "mcp_skill_control"],
            env={**common, "MCP_PORT": str(ports[0])},
        )
        launcher.start(
            "perception",
            [sys.executable, "-m", "mcp_perception_buffer"],
            env={**common, "MCP_PORT": str(ports[1]), "PERCEPTION_GRAPH_POLL_S": "0.2"},
        )
        for port in ports:
            wait_for_tcp_port(port, 30.0)
        time.sleep(2.0)  # let DDS discovery settle (first discovery takes up to ~3 s)
        urls = (f"http://127.0.0.1:{ports[0]}/mcp", f"http://127.0.0.1:{ports[1]}/mcp")
        numbers = asyncio.run(measure(urls, args.skills, args.calls))
    finally:
        launcher.stop_all()
    report = {
        "benchmark": "bridges_latency",
        "vision": args.vision,
        "vision_publish_hz": args.hz if args.vision == "fake" else None,
        "transport": "streamable-http",
        "graph_poll_s": 0.2,
        "machine": {"python": platform.python_version(), "cpus": os.cpu_count()},
        "loadavg": {"start": loadavg_start, "end": Path("/proc/loadavg").read_text().split()[:3]},
        "ts": time.time(),
        **numbers,
    }
    suffix = "" if args.vision == "fake" else "_real"
    results = RESULTS_DIR / f"bridges_latency{suffix}.json"
    results.parent.mkdir(parents=True, exist_ok=True)
    results.write_text(json.dumps(report, indent=2) + "\n", encoding="utf-8")
    print(json.dumps(report, indent=2))


if __name__ == "__main__":
    main()
