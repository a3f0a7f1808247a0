"""What the service plane's credential check costs (issue 27 item 3).

(1) End to end: one MCP tool call (``echo``) over loopback to one tiny server process that
serves the same MCP server object on two ports through ``robot_mcp_kit.mcp_runtime.http_app``:
one behind the credential check (``MCP_AUTH_TOKEN``), one without (``_mcp_echo_server.py``),
for sse and streamable-http. Calls alternate between the two ports (order flipped every round)
so machine load hits both alike; the paired median difference is the steadiest figure.
(2) The check alone: ``BearerAuthMiddleware`` in front of an ASGI app that answers at once,
against that app bare, called in process (no sockets).

Run: ``uv run python benchmarks/mcp_auth_overhead.py [--calls 500]``.
Writes benchmarks/results/mcp_auth_overhead.json.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import statistics
import sys
import time
from collections.abc import MutableMapping
from pathlib import Path
from typing import Any

from mcp import Client

from robot_mcp_kit.service_auth import BearerAuthMiddleware, service_auth
from robot_stack_testing import (
    ProcessLauncher,
    bearer,
    free_tcp_port,
    fresh_token,
    mcp_transport,
    wait_for_tcp_port,
)

RESULTS = Path(__file__).with_name("results")
SERVER = Path(__file__).with_name("_mcp_echo_server.py")
PATHS = {"sse": "/sse", "streamable-http": "/mcp"}
TOKEN = fresh_token()


def percentiles(samples: list[float]) -> dict[str, float]:
    ordered = sorted(samples)
    return {
        "n": len(ordered),
        "p50_ms": round(statistics.median(ordered), 4),
        "p99_ms": round(ordered[max(int(len(ordered) * 0.99) - 1, 0)], 4),
        "max_ms": round(ordered[-1], 4),
    }


async def timed_call(client: Client, text: str) -> float:
    started = time.perf_counter()
    result = await client.call_tool("echo", {"text": text})
    elapsed = (time.perf_counter() - started) * 1000
    assert not result.is_error, result
    return elapsed


async def end_to_end(transport: str, calls: int, work: Path) -> dict[str, Any]:
    launcher = ProcessLauncher(work)
    ports = {"with_check": free_tcp_port(), "without_check": free_tcp_port()}
    try:
        launcher.start(
            f"echo-{transport}",
            [sys.executable, str(SERVER)],
            env={
                "MCP_TRANSPORT": transport,
                "MCP_AUTH_TOKEN": TOKEN,
                "BENCH_PORT_CHECKED": str(ports["with_check"]),
                "BENCH_PORT_OPEN": str(ports["without_check"]),
            },
        )
        for port in ports.values():
            await asyncio.to_thread(wait_for_tcp_port, port, 30.0)
        urls = {m: f"http://127.0.0.1:{p}{PATHS[transport]}" for m, p in ports.items()}
        samples: dict[str, list[float]] = {mode: [] for mode in ports}
        async with (
            Client(mcp_transport(urls["with_check"], TOKEN)) as checked,
            Client(mcp_transport(urls["without_check"], None)) as open_,
        ):
            clients = {"with_check": checked, "without_check": open_}
            for _ in range(50):  # warm-up: connections, first-call paths
                for client in clients.values():
                    await timed_call(client, "warm")
            for index in range(calls):
                order = list(clients) if index % 2 == 0 else list(reversed(clients))
                for mode in order:
                    samples[mode].append(await timed_call(clients[mode], f"call {index}"))
        result: dict[str, Any] = {m: percentiles(s) for m, s in samples.items()}
        result["added_p50_ms"] = round(
            result["with_check"]["p50_ms"] - result["without_check"]["p50_ms"], 4
        )
        result["added_p99_ms"] = round(
            result["with_check"]["p99_ms"] - result["without_check"]["p99_ms"], 4
        )
        # calls alternate, so each round's pair saw the same moment of machine load: the
        # median of the per-round differences is the steadiest figure on a busy machine
        pairs = [
            a - b for a, b in zip(samples["with_check"], samples["without_check"], strict=True)
        ]
        result["paired_median_diff_ms"] = round(statistics.median(pairs), 4)
        return result
    finally:
        launcher.stop_all()


async def _answer(scope: MutableMapping[str, Any], receive: Any, send: Any) -> None:
    await send({"type": "http.response.start", "status": 200, "headers": []})
    await send({"type": "http.response.body", "body": b"{}"})


async def check_alone(requests: int) -> dict[str, Any]:
    auth = service_auth({"MCP_AUTH_TOKEN": TOKEN, "MCP_OPERATOR_TOKEN": fresh_token()}, "sse")
    guarded = BearerAuthMiddleware(_answer, auth, "bench_echo")
    header = bearer(TOKEN)["Authorization"].encode()
    scope = {
        "type": "http",
        "method": "POST",
        "path": "/messages/",
        "headers": [(b"host", b"127.0.0.1"), (b"authorization", header)],
        "client": ("127.0.0.1", 1),
    }

    async def receive() -> dict[str, Any]:
        return {"type": "http.request", "body": b"", "more_body": False}

    async def send(message: Any) -> None:
        return None

    samples: dict[str, list[float]] = {"with_check": [], "without_check": []}
    for _ in range(requests):
        for mode, app in (("without_check", _answer), ("with_check", guarded)):
            started = time.perf_counter()
            await app(dict(scope), receive, send)
            samples[mode].append((time.perf_counter() - started) * 1000)
    result: dict[str, Any] = {m: percentiles(s) for m, s in samples.items()}
    result["added_p50_us"] = round(
        (result["with_check"]["p50_ms"] - result["without_check"]["p50_ms"]) * 1000, 2
    )
    result["added_p99_us"] = round(
        (result["with_check"]["p99_ms"] - result["without_check"]["p99_ms"]) * 1000, 2
    )
    return result


async def measure(calls: int, work: Path) -> dict[str, Any]:
    return {
        "calls_per_mode": calls,
        "load_average_before": list(os.getloadavg()),
        "end_to_end": {t: await end_to_end(t, calls, work) for t in PATHS},
        "check_alone": await check_alone(calls * 20),
        "load_average_after": list(os.getloadavg()),
    }


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--calls", type=int, default=500)
    args = parser.parse_args()
    RESULTS.mkdir(exist_ok=True)
    work = RESULTS / "mcp_auth_overhead-logs"
    work.mkdir(exist_ok=True)
    result = asyncio.run(measure(args.calls, work))
    (RESULTS / "mcp_auth_overhead.json").write_text(json.dumps(result, indent=2))
    for transport, figures in result["end_to_end"].items():
        on, off = figures["with_check"], figures["without_check"]
        print(
            f"{transport}: tool call p50 {on['p50_ms']} ms with the check vs "
            f"{off['p50_ms']} ms without (+{figures['added_p50_ms']} ms), p99 {on['p99_ms']} "
            f"vs {off['p99_ms']} ms (+{figures['added_p99_ms']} ms), paired median difference "
            f"{figures['paired_median_diff_ms']} ms, {on['n']} calls each"
        )
    alone = result["check_alone"]
    print(
        f"the check alone (in process): +{alone['added_p50_us']} µs p50, "
        f"+{alone['added_p99_us']} µs p99 per request; load average "
        f"{result['load_average_before'][0]:.1f} → {result['load_average_after'][0]:.1f}"
    )


if __name__ == "__main__":
    main()
