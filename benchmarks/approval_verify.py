"""What checking a signed approval costs per call (issue 35 item 4).

(1) The check alone: ``ApprovalVerifier.verify`` of a fresh, valid approval (shape, HMAC-SHA256
in constant time, audience, tool, the call digest of the arguments, expiry, single use) for a
small ``forget``-sized argument set and for a 20 KB ``save_process`` document; a forged one
(bad signature) for comparison; the brain's signing (``signed_approval``) too.
(2) Through an in-process MCP server: one ``tools/call`` of a tool that calls
``require_approval()`` against the same tool without it (alternating, paired median
difference), so the figure includes the ``_meta`` plumbing (INFO logging off: the
``approval_accepted`` line is not counted).

Run: ``uv run python benchmarks/approval_verify.py [--calls 20000]``.
Writes benchmarks/results/approval_verify.json.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import statistics
import time
import uuid
from pathlib import Path
from typing import Any, cast

from mcp import Client
from mcp.server.mcpserver import MCPServer
from mcp.types import RequestParamsMeta

from robot_mcp_kit.approvals import (
    APPROVAL_INVALID,
    ApprovalError,
    ApprovalVerifier,
    require_approval,
    signed_approval,
)
from robot_mcp_kit.caller import APPROVAL_META_KEY, install_caller_context
from robot_mcp_kit.logging import configure_logging

RESULTS = Path(__file__).with_name("results")
SECRET = "approval-benchmark-secret-0123456789abcdef"
SMALL = {"start": "-36500d", "end": "now", "label": "mug", "place": "kitchen", "dry_run": False}
DOC = {"markdown": "---\nid: x\n---\n## Steps\n" + "1. go to the mailroom and look\n" * 650}


def percentiles_us(samples: list[float]) -> dict[str, float]:
    ordered = sorted(samples)
    return {
        "n": len(ordered),
        "p50_us": round(statistics.median(ordered), 2),
        "p99_us": round(ordered[max(int(len(ordered) * 0.99) - 1, 0)], 2),
        "max_us": round(ordered[-1], 2),
    }


def entry(tool: str, arguments: dict[str, Any]) -> dict[str, Any]:
    meta = signed_approval(
        SECRET,
        server="bench",
        tool=tool,
        arguments=arguments,
        approval_id=f"ap-{uuid.uuid4().hex[:12]}",
        by="alice",
    )
    value: dict[str, Any] = meta[APPROVAL_META_KEY]
    return value


def verify_cost(calls: int, tool: str, arguments: dict[str, Any]) -> dict[str, Any]:
    verifier = ApprovalVerifier("bench", SECRET, max_remembered=calls + 1)
    entries = [entry(tool, arguments) for _ in range(calls)]
    samples = []
    for value in entries:
        started = time.perf_counter()
        verifier.verify(value, tool, arguments)
        samples.append((time.perf_counter() - started) * 1e6)
    forged_samples = []
    forged = {**entries[0], "by": "mallory"}
    codes: set[str] = set()
    for _ in range(calls):
        started = time.perf_counter()
        try:
            verifier.verify(forged, tool, arguments)
        except ApprovalError as refused:
            codes.add(refused.code)
        forged_samples.append((time.perf_counter() - started) * 1e6)
    if codes != {APPROVAL_INVALID}:
        raise SystemExit(f"a forged approval was not refused every time: {codes}")
    sign_samples = []
    for _ in range(calls):
        started = time.perf_counter()
        entry(tool, arguments)
        sign_samples.append((time.perf_counter() - started) * 1e6)
    return {
        "arguments_bytes": len(json.dumps(arguments)),
        "verify_valid": percentiles_us(samples),
        "verify_forged": percentiles_us(forged_samples),
        "sign": percentiles_us(sign_samples),
        "remembered_after": verifier.remembered(),
    }


def build() -> MCPServer:
    server = MCPServer("bench")

    @server.tool()
    async def gated(start: str, end: str, label: str, place: str, dry_run: bool) -> str:
        """Checks an approval."""
        return require_approval().by

    @server.tool()
    async def open_(start: str, end: str, label: str, place: str, dry_run: bool) -> str:
        """Checks nothing."""
        return "alice"

    return install_caller_context(server, ApprovalVerifier("bench", SECRET, max_remembered=10**6))


async def through_mcp(calls: int) -> dict[str, Any]:
    gated_ms: list[float] = []
    open_ms: list[float] = []
    async with Client(build()) as client:
        for _ in range(50):  # warm up
            await client.call_tool("open_", SMALL)
        for round_ in range(calls):
            order = ("gated", "open_") if round_ % 2 else ("open_", "gated")
            for tool in order:
                meta = {APPROVAL_META_KEY: entry("gated", SMALL)} if tool == "gated" else None
                started = time.perf_counter()
                result = await client.call_tool(
                    tool, SMALL, meta=cast(RequestParamsMeta, meta) if meta else None
                )
                elapsed = (time.perf_counter() - started) * 1e6
                assert not result.is_error, result
                (gated_ms if tool == "gated" else open_ms).append(elapsed)
    paired = [g - o for g, o in zip(gated_ms, open_ms, strict=True)]
    return {
        "gated_call": percentiles_us(gated_ms),
        "open_call": percentiles_us(open_ms),
        "paired_median_difference_us": round(statistics.median(paired), 2),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--calls", type=int, default=20_000)
    parser.add_argument("--mcp-calls", type=int, default=2_000)
    args = parser.parse_args()
    # approval_accepted lines are INFO: left out here (a few approvals a day, not a hot path)
    configure_logging("approval-bench", level="WARNING")
    result = {
        "forget_sized": verify_cost(args.calls, "forget", SMALL),
        "save_process_20kb": verify_cost(args.calls // 4, "save_process", DOC),
        "in_process_mcp": asyncio.run(through_mcp(args.mcp_calls)),
    }
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / "approval_verify.json").write_text(json.dumps(result, indent=2) + "\n")
    for name in ("forget_sized", "save_process_20kb"):
        part = result[name]
        print(
            f"{name} ({part['arguments_bytes']} B of arguments): verify p50 "
            f"{part['verify_valid']['p50_us']} / p99 {part['verify_valid']['p99_us']} µs; "
            f"forged p50 {part['verify_forged']['p50_us']} / p99 "
            f"{part['verify_forged']['p99_us']} µs; sign p50 {part['sign']['p50_us']} µs"
        )
    mcp = result["in_process_mcp"]
    print(
        f"in-process MCP call: gated p50 {mcp['gated_call']['p50_us']} / p99 "
        f"{mcp['gated_call']['p99_us']} µs vs open p50 {mcp['open_call']['p50_us']} / p99 "
        f"{mcp['open_call']['p99_us']} µs; paired median difference "
        f"{mcp['paired_median_difference_us']} µs"
    )


if __name__ == "__main__":
    main()
