"""Benchmark: EventPoster → a local signature-checking receiver (uvicorn on 127.0.0.1).

Measures emit rate (each emit is a durable SQLite commit), delivered events/s and the
emit→delivered latency (emit() returned → receiver accepted) for a burst and for a paced
stream. Bounded: 2,000 burst events + 500 paced events. Poster and receiver share one event
loop and the machine's cores, so the numbers are a floor, not a ceiling.

    uv run python benchmarks/kit_poster.py [--burst 2000] [--paced 500] [--rate 250]

Writes benchmarks/results/kit_poster.json.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import platform
import statistics
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from robot_mcp_kit.logging import configure_logging
from robot_mcp_kit.poster import EventPoster
from robot_stack_testing import free_tcp_port
from robot_stack_testing.kit.receiver import ReceiverServer, RecordingReceiver, order_violations

RESULTS = Path(__file__).parent / "results" / "kit_poster.json"
SECRET = "bench-secret"
TASKS = 20


def percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    index = min(len(ordered) - 1, max(0, round(q / 100 * (len(ordered) - 1))))
    return ordered[index]


async def run_scenario(
    name: str, count: int, rate_hz: float | None, port: int, outbox: Path, timeout_s: float
) -> dict[str, Any]:
    receiver = RecordingReceiver({"bench": SECRET})
    async with ReceiverServer(receiver, port) as server:
        poster = EventPoster(server.url, "bench", SECRET, outbox)
        await poster.start()
        emitted_at: dict[str, float] = {}
        started = time.perf_counter()
        wall_started = time.time()
        for i in range(count):
            event = await poster.emit(f"task-{i % TASKS}", "bench", "progress", {"i": i})
            emitted_at[event.event_id] = time.time()
            if rate_hz:
                next_at = started + (i + 1) / rate_hz
                delay = next_at - time.perf_counter()
                if delay > 0:
                    await asyncio.sleep(delay)
        emit_s = time.perf_counter() - started
        drained = await poster.wait_drained(timeout_s)
        total_s = time.perf_counter() - started
        await poster.close(flush_timeout_s=1)

    accepted = receiver.accepted()
    first_seen: dict[str, float] = {}
    for delivery in accepted:
        first_seen.setdefault(delivery.event.event_id, delivery.received_at)
    latencies_ms = [
        (first_seen[event_id] - at) * 1000
        for event_id, at in emitted_at.items()
        if event_id in first_seen
    ]
    last_delivery = max(first_seen.values(), default=wall_started)
    return {
        "scenario": name,
        "events": count,
        "tasks": TASKS,
        "target_rate_hz": rate_hz,
        "drained": drained,
        "delivered": len(first_seen),
        "duplicates": len(accepted) - len(first_seen),
        "order_violations": len(order_violations(receiver.deliveries)),
        "emit_per_s": round(count / emit_s, 1),
        "delivered_per_s": round(len(first_seen) / max(1e-9, last_delivery - wall_started), 1),
        "total_s": round(total_s, 3),
        "latency_ms": {
            "p50": round(percentile(latencies_ms, 50), 2),
            "p99": round(percentile(latencies_ms, 99), 2),
            "max": round(max(latencies_ms), 2),
            "mean": round(statistics.fmean(latencies_ms), 2),
        },
    }


async def main(burst: int, paced: int, rate: float) -> dict[str, Any]:
    port = free_tcp_port()
    with tempfile.TemporaryDirectory() as tmp:
        scenarios = [
            await run_scenario("burst", burst, None, port, Path(tmp) / "burst.sqlite", 120),
            await run_scenario("paced", paced, rate, port, Path(tmp) / "paced.sqlite", 60),
        ]
    return {
        "benchmark": "kit_poster",
        "python": platform.python_version(),
        "machine": platform.machine(),
        "note": "poster and receiver in one event loop on loopback; SQLite synchronous=FULL",
        "scenarios": scenarios,
    }


def cli(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--burst", type=int, default=2000)
    parser.add_argument("--paced", type=int, default=500)
    parser.add_argument("--rate", type=float, default=250.0)
    args = parser.parse_args(argv)
    configure_logging("kit-bench", level="WARNING")
    result = asyncio.run(main(args.burst, args.paced, args.rate))
    RESULTS.parent.mkdir(parents=True, exist_ok=True)
    RESULTS.write_text(json.dumps(result, indent=2) + "\n")
    for s in result["scenarios"]:
        lat = s["latency_ms"]
        print(
            f"{s['scenario']:>6}: {s['events']} events, emit {s['emit_per_s']}/s, "
            f"delivered {s['delivered']} at {s['delivered_per_s']}/s, "
            f"latency p50 {lat['p50']} ms p99 {lat['p99']} ms, "
            f"dups {s['duplicates']}, order violations {s['order_violations']}"
        )
    print(f"wrote {RESULTS}")
    failed = any(not s["drained"] or s["order_violations"] for s in result["scenarios"])
    sys.exit(1 if failed else 0)


if __name__ == "__main__":
    cli()
