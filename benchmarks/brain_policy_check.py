"""The tool policy check per call (issue 21): the guard's decision (latch, stop tools, the
shipped policy.yaml, bounds, annotation defaults) for the brain's real tool surface — goal
p99 < 1 ms. Also the whole guarded call_tool overhead over a zero-latency fake backend.

Run: ``uv run python benchmarks/brain_policy_check.py [--calls 20000]``.
Writes benchmarks/results/brain_policy_check.json.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import logging
import statistics
import time
from pathlib import Path
from typing import Any

import structlog

from robot_stack_testing.brain.harness import nav_servers
from robot_voice_chat.control.guard import GuardedToolBackend
from robot_voice_chat.control.latch import SafetyLatch
from robot_voice_chat.control.latch_store import MemoryLatchStore
from robot_voice_chat.control.policy import ToolPolicy
from robot_voice_chat.services.tools.fake import FakeToolBackend
from robot_voice_chat.settings import CONFIG_DIR

RESULTS = Path(__file__).with_name("results")
READ = {"readOnlyHint": True}
CALLS: list[tuple[str, dict[str, Any]]] = [
    ("navigation.navigate_to", {"location": "mailroom"}),
    ("navigation.navigate_to", {"location": "roof"}),  # out of bounds
    ("navigation.get_pose", {}),
    ("navigation.cancel_task", {"task_id": "t1"}),
    ("perception.get_history", {"skill": "s", "seconds": 30}),
    ("perception.what_do_you_see", {}),
    ("skill_control.instantiate_skill", {"template": "find_object", "params": {"query": "mug"}}),
    ("memory.find_processes", {"query": "fetch", "k": 3}),
    ("vendor.unknown_tool", {}),  # denied: unknown, no annotations
]


def backend() -> GuardedToolBackend:
    fake = FakeToolBackend(nav_servers())
    for name in {
        *ToolPolicy.load(CONFIG_DIR / "policy.yaml").named_tools(),
        *(n for n, _ in CALLS),
    }:
        fake.add(name, lambda a: "{}")
        if not name.startswith("vendor."):
            fake.annotate(name, READ)
    policy = ToolPolicy.load(CONFIG_DIR / "policy.yaml")
    return GuardedToolBackend(fake, SafetyLatch(MemoryLatchStore()), policy)


def percentiles(samples: list[float]) -> dict[str, float]:
    ordered = sorted(samples)
    return {
        "p50_ms": round(statistics.median(ordered), 4),
        "p99_ms": round(ordered[int(len(ordered) * 0.99) - 1], 4),
        "max_ms": round(ordered[-1], 4),
    }


async def measure(calls: int) -> dict[str, Any]:
    guard = backend()
    decide: list[float] = []
    for i in range(calls):
        name, args = CALLS[i % len(CALLS)]
        t0 = time.perf_counter()
        guard.latched_refusal(name)
        guard.decide(name, args)
        decide.append((time.perf_counter() - t0) * 1000)
    guarded: list[float] = []
    raw: list[float] = []
    for i in range(calls // 4):
        name, args = CALLS[i % len(CALLS)]
        t0 = time.perf_counter()
        await guard.call_tool(name, args)
        guarded.append((time.perf_counter() - t0) * 1000)
        t0 = time.perf_counter()
        await guard.inner.call_tool(name, args)
        raw.append((time.perf_counter() - t0) * 1000)
    return {
        "tools_in_surface": len(guard.list_tools()),
        "calls": calls,
        "policy_check": percentiles(decide),
        "guarded_call_tool": percentiles(guarded),
        "raw_fake_call_tool": percentiles(raw),
    }


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--calls", type=int, default=20000)
    args = parser.parse_args()
    structlog.configure(wrapper_class=structlog.make_filtering_bound_logger(logging.CRITICAL))
    result = asyncio.run(measure(args.calls))
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / "brain_policy_check.json").write_text(json.dumps(result, indent=2))
    check = result["policy_check"]
    print(
        f"policy check over {result['tools_in_surface']} tools: p50 {check['p50_ms']} ms, "
        f"p99 {check['p99_ms']} ms (goal < 1 ms); guarded call_tool p99 "
        f"{result['guarded_call_tool']['p99_ms']} ms vs raw fake "
        f"{result['raw_fake_call_tool']['p99_ms']} ms"
    )


if __name__ == "__main__":
    main()
