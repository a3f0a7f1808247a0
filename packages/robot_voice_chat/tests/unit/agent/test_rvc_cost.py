"""Cost: usage totals per mission (trace, mission_finished, snapshot), the max_cost_usd
budget, and no planner call while the awaited task still reports progress."""

from __future__ import annotations

import time
from pathlib import Path

import pytest

from robot_mcp_kit.models import TaskEvent
from robot_stack_testing import async_wait_until
from robot_stack_testing.brain.harness import make_harness
from robot_voice_chat.agent import task_registry
from robot_voice_chat.services.llm.base import LLMResponse, Usage
from robot_voice_chat.services.llm.fake import FakeLLM, reply
from robot_voice_chat.services.llm.pricing import Prices, priced
from robot_voice_chat.socket_events import MissionFinished


def costly(response: LLMResponse, cost: float) -> LLMResponse:
    usage = Usage(input_tokens=1000, output_tokens=100, cache_read_tokens=50, cost_usd=cost)
    return response.model_copy(update={"usage": usage})


PLAN = reply(
    "",
    ("set_plan", {"steps": [{"id": "s1", "title": "Drive", "tool": "navigation.navigate_to"}]}),
    ("navigation.navigate_to", {"step_id": "s1", "location": "mailroom"}),
)
WAIT = reply("", ("wait_for_events", {"reason": "driving"}))
FINISH = reply("", ("finish_mission", {"outcome": "succeeded", "summary": "done"}))


def test_prices_turn_usage_into_dollars() -> None:
    prices = Prices(input=5.0, output=25.0, cache_read=0.5, cache_write=6.25)
    usage = Usage(input_tokens=1_000_000, output_tokens=2000, cache_read_tokens=10_000)
    assert prices.cost(usage) == 5.0 + 0.05 + 0.005
    assert priced(usage, None).cost_usd is None
    assert priced(usage, prices).cost_usd == 5.055
    total = Usage(input_tokens=1, cost_usd=0.5) + Usage(output_tokens=2)
    assert (total.input_tokens, total.output_tokens, total.cost_usd) == (1, 2, 0.5)


async def test_usage_totals_reach_the_trace_mission_finished_and_the_snapshot(
    tmp_path: Path,
) -> None:
    planner = FakeLLM([costly(PLAN, 0.01), costly(FINISH, 0.02)])
    h = make_harness(tmp_path, planner)
    mission = await h.executor.start("drive")
    await h.executor.wait_idle(5)
    assert mission.state == "succeeded"
    assert mission.usage.input_tokens == 2000
    assert mission.usage.cost_usd == 0.03
    finished = next(e for e in h.emitter.events if isinstance(e, MissionFinished))
    assert finished.usage is not None
    assert finished.usage["cost_usd"] == 0.03
    assert finished.usage["output_tokens"] == 200
    records = await h.trace.read(mission.id)
    final = next(r for r in records if r["kind"] == "final")
    assert final["usage"]["cache_read_tokens"] == 100
    steps = [r for r in records if r["kind"] == "llm_step"]
    assert [s["usage"]["cost_usd"] for s in steps] == [0.01, 0.02]
    assert mission.summary_row()["usage"]["cost_usd"] == 0.03


async def test_max_cost_usd_stops_the_mission_and_cancels_its_task(tmp_path: Path) -> None:
    planner = FakeLLM([costly(PLAN, 0.3), costly(WAIT, 0.3)])
    h = make_harness(tmp_path, planner, max_cost_usd=0.5)
    mission = await h.executor.start("drive")
    await h.executor.wait_idle(5)
    assert mission.state == "failed"
    assert "cost budget of $0.5" in mission.summary
    assert h.tools.called("navigation.cancel_task") == [{"task_id": "nav-1"}]


class RegistryClock:
    """The task registry's ``time``: its monotonic clock stands still unless the test moves
    it; the wall clock is the real one."""

    def __init__(self) -> None:
        self.now = 1000.0

    def monotonic(self) -> float:
        return self.now

    def time(self) -> float:
        return time.time()


async def test_no_planner_call_while_the_awaited_task_still_reports_progress(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    clock = RegistryClock()
    monkeypatch.setattr(task_registry, "time", clock)
    planner = FakeLLM([PLAN, WAIT, FINISH])
    h = make_harness(tmp_path, planner, wakeup_timeout_s=0.05)
    looks: list[bool] = []  # each wakeup timeout asks the registry whether progress came
    progressed = h.executor.registry.progressed

    def looked(mission_id: str, within_s: float) -> bool:
        looks.append(progressed(mission_id, within_s))
        return looks[-1]

    monkeypatch.setattr(h.executor.registry, "progressed", looked)
    await h.executor.start("drive")
    await async_wait_until(lambda: h.executor.run and h.executor.run.suspended, 5, "suspended")
    for seq in range(4):  # a progress report within every timeout window, four timeouts long
        event = TaskEvent(
            task_id="nav-1",
            server="navigation",
            tool="navigate_to",
            type="progress",
            seq=seq,
            ts=time.time(),
            payload={"eta_s": 10 - seq, "pct": 10 * seq},
        )
        await h.executor.on_task_event(event)
        before = len(looks)
        await async_wait_until(lambda: len(looks) > before, 5, "a wakeup timeout")  # noqa: B023
        clock.now += 0.03  # the next report comes within the 0.05 s window
    assert all(looks)
    assert len(planner.requests) == 2  # progress kept the loop waiting: no timeout step
    clock.now += 1.0  # progress stopped → the timeout note wakes the planner
    await h.executor.wait_idle(5)
    assert len(planner.requests) == 3
    assert "[timeout] still waiting" in planner.requests[2][0][-1].content
