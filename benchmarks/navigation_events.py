"""Benchmark: the navigation server posting signed task events while driving N routes.

Starts a local signed-event receiver and the navigation server (a real process, streamable
HTTP, high NAV_TIME_SCALE), drives N routes over MCP and reports: events delivered,
event delivery latency (event ts → verified at the receiver) p50/p99, and MCP tool-call
round trip p50/p99. Bounded to well under a minute. Writes
benchmarks/results/navigation_events.json.

    uv run python benchmarks/navigation_events.py [--routes 40] [--time-scale 100]
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import random
import signal
import socket
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

import uvicorn
from mcp import Client
from mcp_types import CallToolResult, TextContent
from starlette.applications import Starlette
from starlette.requests import Request
from starlette.responses import JSONResponse
from starlette.routing import Route

from robot_mcp_kit.models import TaskEvent
from robot_mcp_kit.signing import HEADER_SIGNATURE, HEADER_TIMESTAMP, SignatureError, verify
from robot_stack_testing import fresh_token, mcp_transport

TOKEN = fresh_token()  # the servers' MCP_AUTH_TOKEN
SECRET = "benchmark-secret"
RESULTS = Path(__file__).parent / "results" / "navigation_events.json"
ROUTE = ["kitchen", "reception", "mailroom", "desk_alice", "corridor_b", "desk_bob", "dock"]
DEADLINE_S = 50.0


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


class Receiver:
    def __init__(self) -> None:
        self.events: list[TaskEvent] = []
        self.latencies_ms: list[float] = []
        self.rejected = 0

    def app(self) -> Starlette:
        async def ingest(request: Request) -> JSONResponse:
            body = await request.body()
            try:
                verify(
                    SECRET,
                    request.headers.get(HEADER_TIMESTAMP, ""),
                    body,
                    request.headers.get(HEADER_SIGNATURE, ""),
                )
            except SignatureError:
                self.rejected += 1
                return JSONResponse({"error": "bad signature"}, status_code=401)
            event = TaskEvent.model_validate_json(body)
            self.latencies_ms.append((time.time() - event.ts) * 1000)
            self.events.append(event)
            return JSONResponse({"status": "ok"})

        return Starlette(routes=[Route("/events", ingest, methods=["POST"])])

    def terminal(self, task_id: str) -> bool:
        return any(
            e.task_id == task_id and e.type in ("task_done", "task_failed") for e in self.events
        )


def text(result: CallToolResult) -> dict[str, Any]:
    content = result.content[0]
    assert isinstance(content, TextContent)
    assert not result.is_error, content.text
    value: dict[str, Any] = json.loads(content.text)
    return value


async def wait_for(predicate: Any, timeout_s: float) -> None:
    deadline = time.monotonic() + timeout_s
    while not predicate():
        if time.monotonic() > deadline:
            raise TimeoutError("benchmark wait timed out")
        await asyncio.sleep(0.005)


async def drive(port: int, receiver: Receiver, routes: int) -> tuple[list[float], int]:
    rtts_ms: list[float] = []
    done = 0
    started = time.monotonic()
    async with Client(mcp_transport(f"http://127.0.0.1:{port}/mcp", TOKEN)) as client:
        for index in range(routes):
            if time.monotonic() - started > DEADLINE_S - 10:
                break
            t0 = time.perf_counter()
            info = text(
                await client.call_tool(
                    "navigate_to",
                    {
                        "location": ROUTE[index % len(ROUTE)],
                        "triggers": [{"type": "eta_below", "seconds": 5}],
                    },
                )
            )
            rtts_ms.append((time.perf_counter() - t0) * 1000)
            t0 = time.perf_counter()
            await client.call_tool("get_pose", {})
            rtts_ms.append((time.perf_counter() - t0) * 1000)
            task_id = info["task_id"]
            await wait_for(lambda tid=task_id: receiver.terminal(tid), 20)
            done += 1
    return rtts_ms, done


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--routes", type=int, default=40)
    parser.add_argument("--time-scale", type=float, default=100.0)
    args = parser.parse_args()

    receiver = Receiver()
    recv_port, nav_port = free_port(), free_port()
    recv_server = uvicorn.Server(
        uvicorn.Config(receiver.app(), host="127.0.0.1", port=recv_port, log_level="warning")
    )
    thread = threading.Thread(target=recv_server.run, daemon=True)
    thread.start()

    with tempfile.TemporaryDirectory() as tmp:
        env = {
            **os.environ,
            "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST",
            "ROS_DOMAIN_ID": str(random.SystemRandom().randint(150, 200)),
            "MCP_TRANSPORT": "streamable-http",
            "MCP_AUTH_TOKEN": TOKEN,
            "MCP_PORT": str(nav_port),
            "RVC_EVENTS_URL": f"http://127.0.0.1:{recv_port}/events",
            "RVC_EVENT_SECRET": SECRET,
            "NAV_OUTBOX": str(Path(tmp) / "outbox.sqlite3"),
            "NAV_TIME_SCALE": str(args.time_scale),
            "NAV_FAILURES": "off",
            "NAV_SUPERVISION": "off",  # no brain: nobody holds a lease
            "NAV_PROGRESS_INTERVAL_S": "0.5",
            "NAV_TICK_S": "0.01",
            "LOG_LEVEL": "WARNING",
        }
        log = (Path(tmp) / "navigation.log").open("wb")
        process = subprocess.Popen(
            [sys.executable, "-m", "robot_mcp_navigation"], env=env, stdout=log, stderr=log
        )
        try:
            deadline = time.monotonic() + 20
            while True:
                try:
                    socket.create_connection(("127.0.0.1", nav_port), timeout=0.2).close()
                    break
                except OSError:
                    if time.monotonic() > deadline or process.poll() is not None:
                        raise RuntimeError("navigation server did not start") from None
                    time.sleep(0.05)
            wall0 = time.monotonic()
            rtts_ms, routes_done = asyncio.run(drive(nav_port, receiver, args.routes))
            wall_s = time.monotonic() - wall0
        finally:
            process.send_signal(signal.SIGTERM)
            try:
                process.wait(timeout=10)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait(timeout=5)
            log.close()
            recv_server.should_exit = True
            thread.join(timeout=10)

    by_type: dict[str, int] = {}
    for event in receiver.events:
        by_type[event.type] = by_type.get(event.type, 0) + 1
    result = {
        "benchmark": "navigation_events",
        "routes_requested": args.routes,
        "routes_completed": routes_done,
        "time_scale": args.time_scale,
        "wall_s": round(wall_s, 2),
        "events_received": len(receiver.events),
        "events_by_type": by_type,
        "events_rejected": receiver.rejected,
        "events_per_s": round(len(receiver.events) / wall_s, 1) if wall_s else None,
        "delivery_latency_ms": {
            "p50": round(percentile(receiver.latencies_ms, 0.5), 2),
            "p99": round(percentile(receiver.latencies_ms, 0.99), 2),
            "mean": round(statistics.fmean(receiver.latencies_ms), 2)
            if receiver.latencies_ms
            else None,
        },
        "tool_call_rtt_ms": {
            "calls": len(rtts_ms),
            "p50": round(percentile(rtts_ms, 0.5), 2),
            "p99": round(percentile(rtts_ms, 0.99), 2),
        },
        "python": sys.version.split()[0],
        "cpu_count": os.cpu_count(),
    }
    RESULTS.parent.mkdir(parents=True, exist_ok=True)
    RESULTS.write_text(json.dumps(result, indent=2) + "\n")
    print(json.dumps(result, indent=2))
    print(f"wrote {RESULTS}")


if __name__ == "__main__":
    main()
