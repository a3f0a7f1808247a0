"""MissionExecutor: happy path, replanning, budgets, no-progress (spec §13)."""

from __future__ import annotations

import time
from pathlib import Path

import pytest

from robot_mcp_kit.models import TaskEvent
from robot_stack_testing import async_wait_until
from robot_stack_testing.brain.harness import Harness, make_harness
from robot_voice_chat.services.llm.fake import FakeLLM, reply
from robot_voice_chat.services.tools.base import ToolOutcome
from robot_voice_chat.socket_events import MissionFinished, MissionPlan, MissionStarted


def event(type_: str, seq: int, **payload: object) -> TaskEvent:
    return TaskEvent(
        task_id="nav-1",
        server="navigation",
        tool="navigate_to",
        type=type_,
        seq=seq,
        ts=time.time(),
        payload=payload,
    )


def conversation(h: Harness) -> str:
    messages = h.planner.requests[-1][0]
    return "\n".join(
        [m.content for m in messages] + [r.content for m in messages for r in m.tool_results]
    )


PLAN = reply(
    "",
    (
        "set_plan",
        {
            "steps": [
                {"id": "s1", "title": "Drive to the mailroom", "tool": "navigation.navigate_to"},
                {"id": "s2", "title": "Tell the user"},
            ]
        },
    ),
    (
        "register_reaction",
        {
            "event": {
                "server": "navigation",
                "type": "trigger_fired",
                "match": {"type": "eta_below"},
            },
            "call": {"tool": "perception.prewarm", "arguments": {"query": "package"}},
        },
    ),
    ("navigation.navigate_to", {"step_id": "s1", "location": "mailroom"}),
)
WAIT = reply("", ("wait_for_events", {"reason": "driving"}))


async def test_happy_path_runs_plan_reaction_and_finishes_with_all_steps_resolved(
    tmp_path: Path,
) -> None:
    planner = FakeLLM(
        [
            PLAN,
            WAIT,
            WAIT,
            reply(
                "",
                ("mark_step", {"step_id": "s2", "status": "succeeded"}),
                ("finish_mission", {"outcome": "succeeded", "summary": "Arrived at the mailroom."}),
            ),
        ]
    )
    h = make_harness(tmp_path, planner)
    mission = await h.executor.start("drive to the mailroom")
    await async_wait_until(lambda: len(planner.requests) == 2, 5, "planner waits for events")
    await async_wait_until(lambda: h.executor.run and h.executor.run.suspended, 5, "suspended")

    await h.executor.on_task_event(event("progress", 0, eta_s=15, pct=40))
    await h.executor.on_task_event(
        event("trigger_fired", 1, eta_s=9.4, trigger={"type": "eta_below", "seconds": 10})
    )
    await async_wait_until(lambda: len(planner.requests) == 3, 5, "woken by the trigger")
    await async_wait_until(lambda: h.executor.run and h.executor.run.suspended, 5, "suspended")
    await h.executor.on_task_event(event("task_done", 2, result={"arrived": "mailroom"}))
    await h.executor.wait_idle(5)

    assert mission.state == "succeeded"
    assert [(s.id, s.status) for s in mission.steps] == [("s1", "succeeded"), ("s2", "succeeded")]
    assert mission.steps[0].task_id == "nav-1"
    assert mission.summary == "Arrived at the mailroom."
    # step_id is stripped before the MCP call; the reaction fired without an LLM hop
    assert h.tools.called("navigation.navigate_to") == [{"location": "mailroom"}]
    assert h.tools.called("perception.prewarm") == [{"query": "package"}]
    text = conversation(h)
    assert "[task nav-1 navigation.navigate_to] trigger_fired: eta_below 10 (eta 9.4s)" in text
    assert "[reaction] eta_below fired → called perception.prewarm" in text
    assert "[task nav-1 navigation.navigate_to] done:" in text
    assert "pct" not in text  # progress never reaches the planner (token hygiene)
    kinds = [type(e) for e in h.emitter.events]
    assert kinds[0] is MissionStarted
    assert kinds[-1] is MissionFinished
    plans = [e for e in h.emitter.events if isinstance(e, MissionPlan)]
    assert any(p.steps and p.steps[0].detail == "ETA 15 s · 40 %" for p in plans)
    assert "Arrived at the mailroom." in h.speech.spoken
    assert h.executor.active is None
    trace_kinds = {r["kind"] for r in await h.trace.read(mission.id)}
    assert {"instruction", "llm_step", "tool_result", "task_event", "final"} <= trace_kinds


async def test_task_failure_wakes_planner_and_update_plan_keeps_terminal_steps(
    tmp_path: Path,
) -> None:
    planner = FakeLLM(
        [
            PLAN,
            WAIT,
            reply(
                "",
                (
                    "update_plan",
                    {
                        "steps": [
                            {"id": "s1", "title": "Drive to the mailroom"},
                            {"id": "s3", "title": "Ask reception to open the door"},
                        ]
                    },
                ),
                ("finish_mission", {"outcome": "failed", "summary": "The door was closed."}),
            ),
        ]
    )
    h = make_harness(tmp_path, planner)
    mission = await h.executor.start("drive to the mailroom")
    await async_wait_until(lambda: h.executor.run and h.executor.run.suspended, 5, "suspended")
    await h.executor.on_task_event(
        event(
            "task_failed",
            0,
            error_code="DOOR_CLOSED",
            message="The mailroom door is closed.",
            recoverable=True,
            suggestions=["ask_reception", "retry_after_s:300"],
        )
    )
    await h.executor.wait_idle(5)

    assert (
        "[task nav-1 navigation.navigate_to] failed DOOR_CLOSED (recoverable): The mailroom door "
        "is closed. suggestions: ask_reception, retry_after_s:300"
    ) in conversation(h)
    statuses = {s.id: s.status for s in mission.steps}
    assert statuses == {"s1": "failed", "s3": "skipped", "s2": "skipped"}
    assert mission.steps[0].detail.startswith("DOOR_CLOSED")
    assert mission.state == "failed"


async def test_step_budget_fails_the_mission_and_cancels_live_tasks(tmp_path: Path) -> None:
    planner = FakeLLM(
        script=lambda m, t: PLAN if len(m) <= 2 else reply("", ("say", {"text": "hm"}))
    )
    h = make_harness(tmp_path, planner, max_llm_steps=3)
    mission = await h.executor.start("drive")
    await h.executor.wait_idle(5)

    assert mission.state == "failed"
    assert "3 planner steps" in mission.summary
    assert h.tools.called("navigation.cancel_task") == [{"task_id": "nav-1"}]
    assert len(planner.requests) == 3


async def test_wall_clock_budget_fails_a_waiting_mission_and_cancels_its_task(
    tmp_path: Path,
) -> None:
    planner = FakeLLM([PLAN, WAIT])
    h = make_harness(tmp_path, planner, max_wall_clock_s=0.3)
    mission = await h.executor.start("drive")
    await h.executor.wait_idle(5)

    assert mission.state == "failed"
    assert "time budget" in mission.summary
    assert h.tools.called("navigation.cancel_task") == [{"task_id": "nav-1"}]
    assert mission.steps[0].status == "failed"


async def test_wakeup_timeout_injects_a_still_waiting_note_with_the_registry(
    tmp_path: Path,
) -> None:
    planner = FakeLLM(
        [PLAN, WAIT, reply("", ("finish_mission", {"outcome": "failed", "summary": "gave up"}))]
    )
    h = make_harness(tmp_path, planner, wakeup_timeout_s=0.05)
    await h.executor.start("drive")
    await h.executor.wait_idle(5)

    assert "[timeout] still waiting after 0.05 s; tasks: nav-1 navigation.navigate_to running" in (
        conversation(h)
    )


async def test_planner_without_tool_calls_is_nudged_once_then_fails_no_progress(
    tmp_path: Path,
) -> None:
    planner = FakeLLM([reply("thinking"), reply("still thinking")])
    h = make_harness(tmp_path, planner)
    mission = await h.executor.start("do something")
    await h.executor.wait_idle(5)

    assert mission.state == "failed"
    assert "no progress" in mission.summary
    assert "You made no tool call" in planner.requests[1][0][-1].content


async def test_planner_error_fails_the_mission_cleanly(tmp_path: Path) -> None:
    from robot_voice_chat.services.llm.base import LLMError

    h = make_harness(tmp_path, FakeLLM([LLMError("overloaded")]))
    mission = await h.executor.start("drive")
    await h.executor.wait_idle(5)
    assert mission.state == "failed"
    # the provider's own words go to the log, the person hears a sentence (issue 31)
    assert mission.summary == "I had to stop the mission: my planner is not answering."


async def test_bad_local_tool_arguments_return_an_error_value_to_the_planner(
    tmp_path: Path,
) -> None:
    planner = FakeLLM(
        [
            reply("", ("mark_step", {"step_id": "nope", "status": "running"})),
            reply("", ("finish_mission", {"outcome": "failed", "summary": "x"})),
        ]
    )
    h = make_harness(tmp_path, planner)
    await h.executor.start("x")
    await h.executor.wait_idle(5)
    result = planner.requests[1][0][-1].tool_results[0]
    assert result.is_error
    assert "no step 'nope'" in result.content


async def test_second_start_is_rejected_while_a_mission_is_active(tmp_path: Path) -> None:
    from robot_voice_chat.agent.run import MissionBusyError

    h = make_harness(tmp_path, FakeLLM([PLAN, WAIT]))
    await h.executor.start("first")
    with pytest.raises(MissionBusyError):
        await h.executor.start("second")
    await h.executor.shutdown()


async def test_a_failed_reaction_call_is_reported_to_the_planner(tmp_path: Path) -> None:
    planner = FakeLLM([PLAN, WAIT, WAIT, WAIT])
    h = make_harness(tmp_path, planner)
    h.tools.add("perception.prewarm", lambda a: ToolOutcome(text="error: offline", is_error=True))
    await h.executor.start("drive to the mailroom")
    await async_wait_until(lambda: h.executor.run and h.executor.run.suspended, 5, "suspended")
    await h.executor.on_task_event(
        event("trigger_fired", 1, eta_s=9.4, trigger={"type": "eta_below", "seconds": 10})
    )
    await async_wait_until(
        lambda: "[reaction] perception.prewarm failed: error: offline" in conversation(h),
        5,
        "the planner hears that the reaction failed",
    )
    await h.executor.shutdown()
