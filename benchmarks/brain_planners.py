"""Planner benchmarks (no network beyond loopback, no keys):

* planner calls and tokens per mailroom mission (door failure → detour → found) through the
  real AnthropicLLM adapter against the strict fake Messages API, the model being a stand-in
  (the rules planner behind the wire), versus a naive loop that calls the model after every
  tool result: one tool call per model turn and, while a task runs, polling get_task instead
  of waiting for events (goal: ≤ 60 % of naive). The fake answers after ``MODEL_LATENCY_S``
  and a drive takes ``DRIVE_S`` (the office map at time-scale 10), so polling costs what it
  would on a robot.
* rules planner: instruction → first tool call dispatched, p50 (goal < 20 ms).

Run: ``uv run python benchmarks/brain_planners.py`` (bounded, under a minute).
Writes benchmarks/results/brain_planners.json.
"""

from __future__ import annotations

import asyncio
import json
import logging
import statistics
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import structlog

from robot_stack_testing.brain.fake_wire import anthropic_responder
from robot_stack_testing.brain.office import office
from robot_stack_testing.fake_anthropic import FakeAnthropicApi
from robot_stack_testing.fake_api_server import serve_in_thread
from robot_voice_chat.services.llm.anthropic import AnthropicLLM
from robot_voice_chat.services.llm.rules.planner import RulesPlanner

RESULTS = Path(__file__).with_name("results")
MAILROOM = "Please fetch the package from the mailroom."
MODEL_LATENCY_S = 0.15
DRIVE_S = 2.0
Blocks = list[dict[str, Any]]


class NaiveModel:
    """The same decisions, made the naive way: one tool call per model turn (the rest of a
    decision is held back for the following turns) and get_task polling while a task runs."""

    def __init__(self, decide: Callable[[dict[str, Any]], Blocks]) -> None:
        self.decide = decide
        self.queue: Blocks = []

    def __call__(self, body: dict[str, Any]) -> Blocks:
        if not self.queue:
            self.queue = [b for b in self.decide(body) if b["type"] == "tool_use"]
        block = self.queue.pop(0)
        if block["name"] == "wait_for_events":
            task_id = _last_task_id(body)
            if task_id is not None:
                return [
                    {
                        "type": "tool_use",
                        "name": "navigation__get_task",
                        "input": {"task_id": task_id},
                    }
                ]
        return [block]


def _last_task_id(body: dict[str, Any]) -> str | None:
    for message in reversed(body["messages"]):
        for block in reversed(message["content"] if isinstance(message["content"], list) else []):
            content = str(block.get("content"))
            if block.get("type") == "tool_result" and '"task_id"' in content:
                try:
                    task_id = json.loads(block["content"]).get("task_id")
                except (ValueError, AttributeError):
                    continue
                if isinstance(task_id, str):
                    return task_id
    return None


async def mailroom(naive: bool) -> dict[str, Any]:
    decide = anthropic_responder(RulesPlanner())
    fake = FakeAnthropicApi(NaiveModel(decide) if naive else decide)
    fake.delay_s = MODEL_LATENCY_S
    with serve_in_thread(fake.app()) as url:
        o = office(Path(tempfile.mkdtemp()), drive_s=DRIVE_S, max_llm_steps=500)
        planner = AnthropicLLM(api_key="bench", base_url=url, max_retries=0)
        o.executor.planner = planner
        started = time.perf_counter()
        mission = await o.run(MAILROOM, timeout_s=300)
        elapsed = time.perf_counter() - started
        await planner.aclose()
    assert mission.state == "succeeded", mission.summary
    assert not fake.rejections, fake.rejections
    usage = mission.usage
    return {
        "planner_calls": len(fake.requests),
        "input_tokens": usage.input_tokens,
        "cache_read_tokens": usage.cache_read_tokens,
        "cache_write_tokens": usage.cache_write_tokens,
        "output_tokens": usage.output_tokens,
        "tokens_total": usage.input_tokens
        + usage.cache_read_tokens
        + usage.cache_write_tokens
        + usage.output_tokens,
        "cost_usd_at_opus_prices": round(
            (
                usage.input_tokens * 5
                + usage.output_tokens * 25
                + usage.cache_read_tokens * 0.5
                + usage.cache_write_tokens * 6.25
            )
            / 1e6,
            5,
        ),
        "mission_s": round(elapsed, 2),
        "drives": [a["location"] for a in o.tools.called("navigation.navigate_to")],
    }


def _timed(original: Any, dispatched: list[float]) -> Any:
    async def timed(name: str, arguments: dict[str, object], timeout_s: float | None = None) -> Any:
        dispatched.append(time.perf_counter())
        return await original(name, arguments, timeout_s)

    return timed


async def first_dispatch(samples: int = 200) -> dict[str, Any]:
    latencies = []
    for _ in range(samples):
        o = office(Path(tempfile.mkdtemp()), drive_s=0.01)
        dispatched: list[float] = []
        o.tools.call_tool = _timed(o.tools.call_tool, dispatched)  # type: ignore[method-assign]
        t0 = time.perf_counter()
        await o.executor.start("go to the kitchen")
        while not dispatched:  # noqa: ASYNC110 - benchmark: first dispatch
            await asyncio.sleep(0)
        latencies.append((dispatched[0] - t0) * 1000)
        await o.executor.wait_idle(10)
    latencies.sort()
    return {
        "samples": samples,
        "instruction_to_first_tool_call_ms_p50": round(statistics.median(latencies), 3),
        "instruction_to_first_tool_call_ms_p99": round(latencies[int(samples * 0.99) - 1], 3),
        "goal_ms_p50": 20,
        "note": "executor.start → rules planner → first MCP dispatch (list_locations)",
    }


def main() -> None:
    structlog.configure(wrapper_class=structlog.make_filtering_bound_logger(logging.WARNING))
    smart = asyncio.run(mailroom(naive=False))
    naive = asyncio.run(mailroom(naive=True))
    result = {
        "mailroom_mission": {
            "event_driven": smart,
            "naive_call_after_every_tool_result": naive,
            "calls_ratio": round(smart["planner_calls"] / naive["planner_calls"], 3),
            "tokens_ratio": round(smart["tokens_total"] / naive["tokens_total"], 3),
            "goal_ratio_max": 0.6,
            "model_latency_s": MODEL_LATENCY_S,
            "drive_s": DRIVE_S,
        },
        "rules_planner": asyncio.run(first_dispatch()),
    }
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / "brain_planners.json").write_text(json.dumps(result, indent=2))
    print(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
