"""Barge-in (spec §9): stop-word pre-scan, motion halted before any LLM call, pause, resume."""

from __future__ import annotations

import asyncio
import json
from pathlib import Path

import pytest

from robot_stack_testing import async_wait_until
from robot_stack_testing.brain.harness import Harness, make_harness, task_info
from robot_voice_chat.agent.bargein import STOP_QUESTION
from robot_voice_chat.services.llm.base import HELD_BY_SAFETY_STOP, ToolCall
from robot_voice_chat.services.llm.fake import FakeLLM, reply
from robot_voice_chat.services.tools.base import ToolOutcome

PLAN = reply(
    "",
    ("set_plan", {"steps": [{"id": "s1", "title": "Drive", "tool": "navigation.navigate_to"}]}),
    ("navigation.navigate_to", {"step_id": "s1", "location": "mailroom"}),
)
WAIT = reply("", ("wait_for_events", {"reason": "driving"}))


async def test_stop_word_cancels_motion_calls_safety_tool_pauses_and_asks(tmp_path: Path) -> None:
    planner = FakeLLM(
        [
            PLAN,
            WAIT,
            reply(
                "",
                (
                    "update_plan",
                    {"steps": [{"id": "s1", "title": "Drive"}, {"id": "s2", "title": "Resume"}]},
                ),
                ("finish_mission", {"outcome": "succeeded", "summary": "Resumed and done."}),
            ),
        ]
    )
    h = make_harness(tmp_path, planner)
    mission = await h.executor.start("drive to the mailroom")
    await async_wait_until(lambda: h.executor.run and h.executor.run.suspended, 5, "suspended")
    requests_before = len(planner.requests)

    await h.executor.on_user_turn("Stop! now")

    assert h.tools.called("navigation.cancel_task") == [{"task_id": "nav-1"}]
    assert h.tools.called("navigation.stop_navigation") == [{}]
    assert len(planner.requests) == requests_before  # no LLM in the stop path
    assert h.speech.interrupts == 1
    assert mission.state == "paused"
    assert mission.steps[0].status == "failed"
    assert mission.steps[0].detail == "safety stop"
    assert STOP_QUESTION == "Stopped. Should I continue or abort?"
    assert h.speech.spoken[-2:] == ["Stopped.", "Should I continue or abort?"]
    run = h.executor.run
    assert run is not None
    run.post("[event] nav-1 task_failed: cancelled")  # a late note wakes the paused loop
    await async_wait_until(lambda: not run.wakeup.is_set(), 5, "the loop looked at its inbox")
    assert run.suspended  # stays suspended while paused: the note waits for the answer
    assert len(planner.requests) == requests_before

    await h.latch.clear("operator", "checked")  # an operator clears the stop first
    await h.executor.on_user_turn("continue please")
    await h.executor.wait_idle(5)
    mission = h.executor.store.get(mission.id) or mission
    last_input = planner.requests[-1][0][-1].content
    assert "paused after a safety stop" in last_input
    assert "User: continue please" in last_input
    assert mission.state == "succeeded"


async def test_stop_during_a_planner_call_cancels_that_call(tmp_path: Path) -> None:
    gate = asyncio.Event()
    finish = reply("", ("finish_mission", {"outcome": "failed", "summary": "aborted"}))
    planner = FakeLLM([PLAN, finish], gate=gate, gate_on_call=2)
    h = make_harness(tmp_path, planner)
    mission = await h.executor.start("drive")
    await async_wait_until(
        lambda: (
            len(planner.requests) == 2
            and h.executor.run is not None
            and h.executor.run.llm_call is not None
        ),
        5,
        "second planner call in flight",
    )

    await h.executor.safety_stop("test")
    gate.set()

    assert mission.state == "paused"
    assert h.tools.called("navigation.cancel_task") == [{"task_id": "nav-1"}]
    await h.executor.on_user_turn("abort")
    await h.executor.wait_idle(5)
    mission = h.executor.store.get(mission.id) or mission
    assert mission.state == "failed"
    assert len(planner.requests) == 3  # the interrupted step's answer was never used


async def test_a_stop_while_the_drive_call_is_in_flight_ends_the_drive_it_started(
    tmp_path: Path,
) -> None:
    """The stop's cancel cannot see a task whose navigate_to has not answered yet: when the
    answer comes, the dispatcher ends that task as the stop would have (step failed, cancelled,
    not a live task whose events reach the planner)."""
    planner = FakeLLM([PLAN, WAIT])
    h = make_harness(tmp_path, planner)
    sent, release = asyncio.Event(), asyncio.Event()

    async def slow_navigate(args: dict[str, object]) -> str:
        sent.set()
        await asyncio.wait_for(release.wait(), 5)
        return task_info("nav-1")

    h.tools.add("navigation.navigate_to", slow_navigate, location="string")
    mission = await h.executor.start("drive to the mailroom")
    await asyncio.wait_for(sent.wait(), 5)

    await h.executor.on_user_turn("stop")
    assert mission.state == "paused"
    assert h.tools.called("navigation.cancel_task") == []  # nothing to cancel yet
    assert (mission.steps[0].status, mission.steps[0].detail) == ("failed", "safety stop")
    release.set()
    await async_wait_until(
        lambda: h.tools.called("navigation.cancel_task"), 5, "the late drive cancelled"
    )

    assert h.tools.called("navigation.cancel_task") == [{"task_id": "nav-1"}]
    assert (mission.steps[0].status, mission.steps[0].detail) == ("failed", "safety stop")
    assert h.executor.task_server("nav-1") is None
    assert mission.state == "paused"
    await h.executor.shutdown()


async def drive_call_decided(h: Harness, mission_id: str) -> bool:
    """The dispatcher has settled the planned drive: held back by the stop, or answered."""
    records = await h.trace.read(mission_id)
    return any(
        r["kind"] in ("tool_held", "tool_result") and r.get("tool") == "navigation.navigate_to"
        for r in records
    )


async def test_a_drive_planned_before_the_stop_is_never_sent(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The stop lands after the planner chose navigate_to but before the call went out (here:
    while the dispatcher logs it): the robot must not start moving only to be cancelled."""
    planner = FakeLLM([PLAN, WAIT])
    h = make_harness(tmp_path, planner)
    about_to_send, release = asyncio.Event(), asyncio.Event()
    output = h.executor.dispatcher.output
    log_line = output.log_line

    async def slow_log_line(run: object, kind: str, text: str) -> None:
        if kind == "tool_call" and "navigate_to" in text:
            about_to_send.set()
            await asyncio.wait_for(release.wait(), 5)
        await log_line(run, kind, text)  # type: ignore[arg-type]

    monkeypatch.setattr(output, "log_line", slow_log_line)
    mission = await h.executor.start("drive to the mailroom")
    await asyncio.wait_for(about_to_send.wait(), 5)

    await h.executor.on_user_turn("stop")
    release.set()
    await async_wait_until(lambda: drive_call_decided(h, mission.id), 5, "the drive settled")

    assert h.tools.called("navigation.navigate_to") == []  # never sent
    assert h.tools.called("navigation.cancel_task") == []  # so nothing to cancel
    assert (mission.steps[0].status, mission.steps[0].detail) == ("failed", "safety stop")
    assert mission.state == "paused"
    await h.executor.shutdown()


async def test_a_motion_call_while_a_stop_awaits_its_answer_is_refused_unsent(
    tmp_path: Path,
) -> None:
    h = make_harness(tmp_path, FakeLLM([PLAN, WAIT]))
    await h.executor.start("drive to the mailroom")
    await async_wait_until(lambda: h.executor.run and h.executor.run.suspended, 5, "suspended")
    await h.executor.on_user_turn("stop")
    run = h.executor.run
    assert run is not None

    call = ToolCall(id="late", name="navigation.navigate_to", arguments={"location": "x"})
    result = await h.executor.dispatcher.execute(run, call)

    assert result.is_error
    assert json.loads(result.content)["error"] == HELD_BY_SAFETY_STOP
    assert len(h.tools.called("navigation.navigate_to")) == 1  # only the drive before the stop
    assert run.mission.state == "paused"
    await h.executor.shutdown()


async def test_stop_without_a_mission_still_halts_motion_servers(tmp_path: Path) -> None:
    h = make_harness(tmp_path, FakeLLM([]))
    await h.executor.safety_stop("stop_pipeline")
    assert h.tools.called("navigation.stop_navigation") == [{}]
    assert h.speech.interrupts == 1


def test_stop_words_match_whole_words_only(tmp_path: Path) -> None:
    h = make_harness(tmp_path, FakeLLM([]))
    assert h.executor.is_stop("Halt!")
    assert h.executor.is_stop("please STOP")
    assert not h.executor.is_stop("the bus stopped here")
    assert not h.executor.is_stop("unstoppable")


def test_a_stop_word_anywhere_in_a_long_utterance_stops(tmp_path: Path) -> None:
    h = make_harness(tmp_path, FakeLLM([]))
    assert h.executor.is_stop("okay so the thing is that over there you should really stop")


def test_negated_stop_words_still_stop_by_design(tmp_path: Path) -> None:
    """README "Barge-in": a needless stop costs a question, a missed stop a collision."""
    h = make_harness(tmp_path, FakeLLM([]))
    assert h.executor.is_stop("don't stop")
    assert h.executor.is_stop("no, do not halt yet")


WATCHER = {
    "skill_id": "watch_for",
    "task_id": "watch-watch_for",
    "state": "running",
    "server": "perception",
    "tool": "instantiate_skill",
}


def add_skill_tools(h: Harness) -> None:
    skills = {"watch_for": WATCHER, "find_object": {"skill_id": "find_object", "mode": "x"}}
    h.tools.add(
        "skill_control.instantiate_skill",
        lambda a: skills[a["template"]],
        template="string",
    )
    h.tools.add("skill_control.stop_skill", lambda a: {"stopped": True}, skill_id="string")
    h.tools.add("perception.cancel_task", lambda a: {"state": "cancelled"}, task_id="string")


START_SKILLS = reply(
    "",
    ("skill_control.instantiate_skill", {"template": "watch_for"}),
    ("skill_control.instantiate_skill", {"template": "find_object"}),
)


async def test_safety_stop_ends_watchers_and_stops_the_skills_the_brain_started(
    tmp_path: Path,
) -> None:
    h = make_harness(tmp_path, FakeLLM([START_SKILLS, WAIT]))
    add_skill_tools(h)
    await h.executor.start("watch the door")
    await async_wait_until(lambda: h.executor.run and h.executor.run.suspended, 5, "suspended")
    assert h.executor.task_server("watch-watch_for") == "perception"

    await h.executor.on_user_turn("stop")

    assert h.tools.called("perception.cancel_task") == [{"task_id": "watch-watch_for"}]
    assert sorted(a["skill_id"] for a in h.tools.called("skill_control.stop_skill")) == [
        "find_object",
        "watch_for",
    ]
    assert h.tools.called("skill_control.cancel_task") == []
    assert h.executor.skills.active() == []
    await h.executor.shutdown()


async def test_the_mission_is_paused_before_slow_skill_stops_finish(tmp_path: Path) -> None:
    planner = FakeLLM([START_SKILLS, WAIT])
    h = make_harness(tmp_path, planner)
    add_skill_tools(h)
    release = asyncio.Event()
    stopping = asyncio.Event()

    async def slow_stop(args: dict[str, object]) -> dict[str, bool]:
        stopping.set()
        await asyncio.wait_for(release.wait(), 5)
        return {"stopped": True}

    h.tools.add("skill_control.stop_skill", slow_stop, skill_id="string")
    mission = await h.executor.start("watch the door")
    await async_wait_until(lambda: h.executor.run and h.executor.run.suspended, 5, "suspended")
    requests_before = len(planner.requests)

    stop = asyncio.create_task(h.executor.on_user_turn("stop"))
    await asyncio.wait_for(stopping.wait(), 5)
    assert mission.state == "paused"  # already, while the skills are still stopping
    assert h.executor.run is not None
    assert h.executor.run.awaiting_user
    release.set()
    await asyncio.wait_for(stop, 5)
    assert len(planner.requests) == requests_before
    await h.executor.shutdown()


async def test_a_drive_the_server_refused_because_the_stop_latched_on_its_way_waits_to_resume(
    tmp_path: Path,
) -> None:
    """The stop latches while navigate_to is on its way and the server, already latched by the
    lease, refuses it: that refusal is the stop's doing — the planner is told the call was held
    by the stop (and waits for continue), not that the mission's drive failed."""
    planner = FakeLLM([PLAN, WAIT])
    h = make_harness(tmp_path, planner)
    sent, release = asyncio.Event(), asyncio.Event()

    async def refused_late(args: dict[str, object]) -> object:
        sent.set()
        await asyncio.wait_for(release.wait(), 5)
        detail = "a software stop is latched: this server refuses every motion"
        return ToolOutcome(
            text=json.dumps({"error": "SAFETY_STOP_LATCHED", "detail": detail}), is_error=True
        )

    h.tools.add("navigation.navigate_to", refused_late, location="string")
    mission = await h.executor.start("drive to the mailroom")
    await asyncio.wait_for(sent.wait(), 5)
    await h.executor.on_user_turn("stop")
    run = h.executor.run
    assert run is not None
    release.set()

    def results() -> list[str]:
        return [r.content for m in run.messages for r in m.tool_results]

    await async_wait_until(
        lambda: any(HELD_BY_SAFETY_STOP in r for r in results()), 5, "the held call in history"
    )
    assert not any("SAFETY_STOP_LATCHED" in r for r in results())
    assert (mission.steps[0].status, mission.steps[0].detail) == ("failed", "safety stop")
    assert mission.state == "paused"
    await h.executor.shutdown()
