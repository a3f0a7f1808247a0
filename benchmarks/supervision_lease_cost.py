"""What the brain's lease (issue 27) costs a tool call.

1. **Over MCP, a real navigation server process** (SSE, simulated base, supervision required):
   ``get_pose`` round trips from one client, N calls with a second client renewing the lease
   as the brain does (every 0.25 s, TTL 0.8 s) and N calls without; plus the renewal's own
   round trip (``supervise``).
2. **In the brain**: ``GuardedToolBackend.call_tool`` for a motion tool with and without the
   supervisor (a fresh lease: the check is one look at it), fake backend, no network.
3. **In the server**: ``Supervision.refusal()`` — the check every motion call makes.

Run: ``uv run python benchmarks/supervision_lease_cost.py [--calls 400]``.
Writes benchmarks/results/supervision_lease_cost.json.
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import json
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from mcp import Client

from robot_mcp_kit.supervision import Supervision
from robot_stack_testing.mcp_auth import fresh_token, mcp_transport
from robot_stack_testing.ports import free_tcp_port, wait_for_tcp_port
from robot_stack_testing.processes import ProcessLauncher
from robot_voice_chat.control.guard import GuardedToolBackend
from robot_voice_chat.control.latch import SafetyLatch
from robot_voice_chat.control.latch_store import MemoryLatchStore
from robot_voice_chat.control.supervisor import MotionSupervisor
from robot_voice_chat.services.tools.fake import FakeToolBackend
from robot_voice_chat.settings import McpServerConfig

RESULTS = Path(__file__).with_name("results")
TOKEN = fresh_token()  # the navigation server's credential (MCP_AUTH_TOKEN) for this run


def percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, max(0, round(q * (len(ordered) - 1))))]


def summary(values: list[float], unit: str = "ms") -> dict[str, Any]:
    return {
        "n": len(values),
        f"p50_{unit}": round(percentile(values, 0.5), 3),
        f"p99_{unit}": round(percentile(values, 0.99), 3),
        f"mean_{unit}": round(statistics.fmean(values), 3),
    }


async def get_pose_rtts(url: str, calls: int) -> list[float]:
    rtts = []
    async with Client(mcp_transport(url, TOKEN)) as client:
        for _ in range(calls):
            started = time.perf_counter()
            await client.call_tool("get_pose", {})
            rtts.append((time.perf_counter() - started) * 1000)
    return rtts


async def renew_forever(url: str, rtts: list[float]) -> None:
    async with Client(mcp_transport(url, TOKEN)) as client:
        while True:
            started = time.perf_counter()
            await client.call_tool("supervise", {"holder": "bench", "latched": False, "ttl_s": 0.8})
            rtts.append((time.perf_counter() - started) * 1000)
            await asyncio.sleep(max(0.0, 0.25 - (time.perf_counter() - started)))


async def over_mcp(url: str, calls: int, blocks: int = 10) -> dict[str, Any]:
    """Blocks of ``get_pose`` calls with and without a renewing brain, alternated so that
    the machine's load changes hit both alike."""
    await get_pose_rtts(url, 20)  # warm up
    renewals: list[float] = []
    with_lease: list[float] = []
    without: list[float] = []
    per_block = max(1, calls // blocks)
    for block in range(blocks * 2):
        if block % 2 == 0:
            renewing = asyncio.create_task(renew_forever(url, renewals))
            await asyncio.sleep(0.3)  # the renewing client connected and renewing
            with_lease += await get_pose_rtts(url, per_block)
            renewing.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await renewing
        else:
            without += await get_pose_rtts(url, per_block)
    return {
        "get_pose_with_lease_renewals": summary(with_lease),
        "get_pose_without": summary(without),
        "added_p50_ms": round(percentile(with_lease, 0.5) - percentile(without, 0.5), 3),
        "added_p99_ms": round(percentile(with_lease, 0.99) - percentile(without, 0.99), 3),
        "supervise_round_trip": summary(renewals),
    }


async def in_the_brain(calls: int) -> dict[str, Any]:
    tools = FakeToolBackend(
        [McpServerConfig(name="navigation", url="http://127.0.0.1:9/sse", motion=True)]
    )
    tools.add("navigation.navigate_to", lambda a: {"task_id": "nav-1"}, location="string")
    tools.add("navigation.supervise", lambda a: {"supervised": True, "latched": False})
    latch = SafetyLatch(MemoryLatchStore())
    supervisor = MotionSupervisor(tools, latch, period_s=0.25, ttl_s=0.8)
    await supervisor.start()
    await asyncio.sleep(0.05)  # the first renewal
    timings: dict[str, list[float]] = {}
    for name, guard in (
        ("without_supervisor", GuardedToolBackend(tools, latch)),
        ("with_supervisor", GuardedToolBackend(tools, latch, supervisor=supervisor)),
    ):
        samples = []
        for _ in range(calls):
            started = time.perf_counter()
            await guard.call_tool("navigation.navigate_to", {"location": "kitchen"})
            samples.append((time.perf_counter() - started) * 1e6)
        timings[name] = samples
    await supervisor.aclose()
    return {
        "guarded_motion_call_without_supervisor": summary(timings["without_supervisor"], "us"),
        "guarded_motion_call_with_supervisor": summary(timings["with_supervisor"], "us"),
    }


def in_the_server(calls: int) -> dict[str, Any]:
    supervision = Supervision()
    supervision.renew("bench", 0.8, latched=False)
    samples = []
    for _ in range(calls):
        started = time.perf_counter()
        supervision.refusal()
        samples.append((time.perf_counter() - started) * 1e6)
    return {"server_refusal_check": summary(samples, "us")}


async def run(url: str, calls: int) -> dict[str, Any]:
    load = os.getloadavg()
    report: dict[str, Any] = {"benchmark": "supervision_lease_cost", "calls": calls}
    report.update(await over_mcp(url, calls))
    report.update(await in_the_brain(calls * 5))
    report.update(in_the_server(calls * 50))
    report["load_average"] = [round(v, 2) for v in (*load, *os.getloadavg())]
    return report


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--calls", type=int, default=400)
    args = parser.parse_args()
    port = free_tcp_port()
    with tempfile.TemporaryDirectory() as tmp:
        launcher = ProcessLauncher(Path(tmp))
        launcher.start(
            "navigation",
            [sys.executable, "-m", "robot_mcp_navigation"],
            env={
                "MCP_TRANSPORT": "sse",
                "MCP_PORT": str(port),
                "NAV_OUTBOX": str(Path(tmp) / "outbox.sqlite3"),
                "NAV_POSE_PATH": str(Path(tmp) / "pose.json"),
                "LOG_LEVEL": "WARNING",
                "MCP_AUTH_TOKEN": TOKEN,
            },
        )
        try:
            wait_for_tcp_port(port, 30)
            report = asyncio.run(run(f"http://127.0.0.1:{port}/sse", args.calls))
        finally:
            launcher.stop_all()
    RESULTS.mkdir(exist_ok=True)
    out = RESULTS / "supervision_lease_cost.json"
    out.write_text(json.dumps(report, indent=2))
    print(json.dumps(report, indent=2))
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
