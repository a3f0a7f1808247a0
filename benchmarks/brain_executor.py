"""Brain executor benchmarks (fakes at every port, no network):

* stop word → motion ``cancel_task`` dispatched (goal < 50 ms; no LLM in the path);
* executor overhead per planner step with a zero-latency fake planner.

Run: ``uv run python benchmarks/brain_executor.py`` (bounded, a few seconds).
Writes benchmarks/results/brain_executor.json.
"""

from __future__ import annotations

import asyncio
import json
import logging
import statistics
import tempfile
import time
from pathlib import Path
from typing import Any

import structlog

from robot_stack_testing.brain.harness import make_harness
from robot_voice_chat.services.llm.fake import FakeLLM, reply

RESULTS = Path(__file__).with_name("results")
PLAN = reply(
    "",
    ("set_plan", {"steps": [{"id": "s1", "title": "Drive", "tool": "navigation.navigate_to"}]}),
    ("navigation.navigate_to", {"step_id": "s1", "location": "mailroom"}),
)
WAIT = reply("", ("wait_for_events", {"reason": "driving"}))


async def stop_latency(samples: int = 100) -> dict[str, Any]:
    results = []
    for _ in range(samples):
        planner = FakeLLM([PLAN, WAIT])
        h = make_harness(Path(tempfile.mkdtemp()), planner)
        dispatched: list[float] = []
        h.tools.add(
            "navigation.cancel_task", lambda a, d=dispatched: d.append(time.perf_counter()) or "ok"
        )
        await h.executor.start("drive to the mailroom")
        run = h.executor.run
        assert run is not None
        while not run.suspended:  # noqa: ASYNC110 - benchmark setup
            await asyncio.sleep(0.001)
        requests = len(planner.requests)
        t0 = time.perf_counter()
        await h.executor.on_user_turn("stop")
        results.append((dispatched[0] - t0) * 1000)
        assert len(planner.requests) == requests  # no LLM in the stop path
        await h.executor.shutdown()
    results.sort()
    return {
        "samples": samples,
        "stop_to_cancel_task_ms_p50": round(statistics.median(results), 3),
        "stop_to_cancel_task_ms_p99": round(results[int(samples * 0.99) - 1], 3),
        "stop_to_cancel_task_ms_max": round(results[-1], 3),
        "goal_ms": 50,
    }


async def step_overhead(steps: int = 400) -> dict[str, Any]:
    """Each planner step calls a local tool (mark_step) and one MCP tool via the fake backend."""
    calls = [
        ("mark_step", {"step_id": "s1", "status": "running"}),
        ("perception.prewarm", {"step_id": "s1", "query": "package"}),
    ]
    script = [reply("", ("set_plan", {"steps": [{"id": "s1", "title": "Look"}]}))]
    script += [reply("", *calls) for _ in range(steps)]
    script.append(reply("", ("finish_mission", {"outcome": "succeeded", "summary": "done"})))
    planner = FakeLLM(script, record=False)  # type: ignore[arg-type]
    h = make_harness(Path(tempfile.mkdtemp()), planner, max_llm_steps=steps + 10)
    t0 = time.perf_counter()
    mission = await h.executor.start("look around")
    await h.executor.wait_idle(60)
    elapsed = time.perf_counter() - t0
    assert mission.state == "succeeded", mission.summary
    return {
        "planner_steps": steps + 2,
        "tool_calls_per_step": len(calls),
        "overhead_ms_per_step": round(elapsed * 1000 / (steps + 2), 3),
        "note": "includes trace buffering/flush, plan snapshots and UI events; planner is instant",
    }


def main() -> None:
    structlog.configure(wrapper_class=structlog.make_filtering_bound_logger(logging.WARNING))
    result = {"barge_in": asyncio.run(stop_latency()), "executor": asyncio.run(step_overhead())}
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / "brain_executor.json").write_text(json.dumps(result, indent=2))
    print(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
