"""While the software stop is latched nothing moves: motion calls refused, no new missions,
and clearing it resumes nothing."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from robot_stack_testing import async_wait_until
from robot_stack_testing.brain.harness import make_harness
from robot_voice_chat.agent.run import SafetyStopLatchedError
from robot_voice_chat.control.latch import SAFETY_STOP_LATCHED
from robot_voice_chat.control.latch_store import FileLatchStore
from robot_voice_chat.services.llm.fake import FakeLLM, reply

PLAN = reply(
    "",
    ("set_plan", {"steps": [{"id": "s1", "title": "Drive", "tool": "navigation.navigate_to"}]}),
    ("navigation.navigate_to", {"step_id": "s1", "location": "mailroom"}),
)
WAIT = reply("", ("wait_for_events", {"reason": "driving"}))


async def test_a_stop_word_latches_and_continue_is_answered_with_the_latch_not_sent_on(
    tmp_path: Path,
) -> None:
    """Issue 32: "continue" while the stop is latched says an operator must clear it; the
    mission stays paused (nothing is sent) and goes on once the stop is cleared."""
    again = reply("", ("navigation.navigate_to", {"step_id": "s1", "location": "mailroom"}))
    planner = FakeLLM([PLAN, WAIT, again, WAIT])
    h = make_harness(tmp_path, planner, latch_store=FileLatchStore(tmp_path / "safety"))
    mission = await h.executor.start("drive to the mailroom")
    await async_wait_until(lambda: h.executor.run and h.executor.run.suspended, 5, "suspended")

    await h.executor.on_user_turn("stop")

    assert h.latch.latched
    assert "stop" in (h.latch.state.reason or "")
    assert FileLatchStore(tmp_path / "safety").load().latched  # persisted before we return
    requests = len(planner.requests)
    for said in ("continue", "carry on", "yes"):  # the person answers; the latch still holds
        answer = await h.executor.on_user_turn(said)
        assert "An operator must press Clear stop" in answer
    assert mission.state == "paused"
    assert len(planner.requests) == requests  # not passed on: no planner step
    assert len(h.tools.called("navigation.navigate_to")) == 1  # only the drive before the stop

    await h.latch.clear("bob", "corridor checked")
    await h.executor.on_user_turn("continue")
    await async_wait_until(
        lambda: len(h.tools.called("navigation.navigate_to")) == 2, 5, "drive after the clear"
    )
    await h.executor.shutdown()


async def test_abort_while_latched_still_reaches_the_paused_mission(tmp_path: Path) -> None:
    finish = reply("", ("finish_mission", {"outcome": "failed", "summary": "Aborted."}))
    h = make_harness(tmp_path, FakeLLM([PLAN, WAIT, finish]))
    mission = await h.executor.start("drive to the mailroom")
    await async_wait_until(lambda: h.executor.run and h.executor.run.suspended, 5, "suspended")
    await h.executor.on_user_turn("halt")

    await h.executor.on_user_turn("abort")
    await h.executor.wait_idle(5)

    assert mission.state == "failed"
    assert h.latch.latched  # aborting clears nothing


async def test_stop_and_read_tools_still_pass_while_latched(tmp_path: Path) -> None:
    h = make_harness(tmp_path, FakeLLM([]))
    await h.executor.safety_stop("test")
    tools = h.executor.tools
    assert not (await tools.call_tool("navigation.cancel_task", {"task_id": "x"})).is_error
    assert not (await tools.call_tool("navigation.stop_navigation", {})).is_error
    assert not (await tools.call_tool("navigation.list_tasks", {"states": []})).is_error
    refused = await tools.call_tool("navigation.navigate_to", {"location": "lab"})
    assert json.loads(refused.text)["error"] == SAFETY_STOP_LATCHED


async def test_new_missions_are_refused_with_a_sentence_saying_why(tmp_path: Path) -> None:
    h = make_harness(tmp_path, FakeLLM([PLAN]))
    await h.executor.safety_stop("Stop robot (operator UI)", by="alice")

    with pytest.raises(SafetyStopLatchedError) as refused:
        await h.executor.start("go to the kitchen")
    assert "software stop is latched" in str(refused.value)
    assert "by alice" in str(refused.value)
    assert "Clear stop" in str(refused.value)
    assert h.executor.active is None
    assert h.tools.called("navigation.navigate_to") == []


async def test_clearing_the_stop_resumes_nothing(tmp_path: Path) -> None:
    planner = FakeLLM([PLAN, WAIT])
    h = make_harness(tmp_path, planner)
    mission = await h.executor.start("drive to the mailroom")
    await async_wait_until(lambda: h.executor.run and h.executor.run.suspended, 5, "suspended")
    await h.executor.on_user_turn("halt")
    calls_before, requests_before = len(h.tools.calls), len(planner.requests)

    await h.latch.clear("bob", "corridor checked")

    assert not h.latch.latched
    assert mission.state == "paused"  # still waiting for the person's answer
    run = h.executor.run
    assert run is not None
    assert run.awaiting_user
    assert len(h.tools.calls) == calls_before  # nothing sent
    assert len(planner.requests) == requests_before  # no planner step either
    await h.executor.shutdown()


async def test_after_clear_a_new_mission_drives(tmp_path: Path) -> None:
    h = make_harness(tmp_path, FakeLLM([PLAN, WAIT]))
    await h.executor.safety_stop("stop", by="alice")
    await h.latch.clear("alice", "safe again")

    await h.executor.start("drive to the mailroom")
    await async_wait_until(lambda: h.tools.called("navigation.navigate_to"), 5, "drive sent")
    await h.executor.shutdown()
