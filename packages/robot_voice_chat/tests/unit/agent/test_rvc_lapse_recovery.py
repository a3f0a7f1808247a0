"""A mission recovers from a supervision lapse with the brain alive (issue 39 item 1): the drive
the server cancelled is re-issued within the same mission, said once; never while the stop is
latched, never after an operator's stop, never more than MAX_RECOVERIES times for one step. A
drive refused NOT_SUPERVISED as it was sent is sent again once the lock is open. A drive whose base
went silent for a moment (BASE_UNAVAILABLE) is re-issued the same way once the base shows a fresh
pose again; a base that stays silent fails the step as it came."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import pytest

from robot_mcp_kit.models import TaskEvent
from robot_mcp_kit.supervision import LAPSE_REASONS
from robot_stack_testing import async_wait_until
from robot_stack_testing.brain.harness import Harness, make_harness, task_info
from robot_voice_chat.agent import step_recovery
from robot_voice_chat.agent.lapse import (
    MAX_RECOVERIES,
    IssuedCall,
    base_answers,
    carrying_on,
    is_lapse,
    lost_link,
    refused_unsupervised,
)
from robot_voice_chat.robot_words import leaks
from robot_voice_chat.services.llm.fake import FakeLLM, reply
from robot_voice_chat.services.tools.base import ToolOutcome

PLAN = reply(
    "",
    ("set_plan", {"steps": [{"id": "s1", "title": "Drive", "tool": "navigation.navigate_to"}]}),
    ("navigation.navigate_to", {"step_id": "s1", "location": "kitchen"}),
)
WAIT = reply("", ("wait_for_events", {"reason": "driving"}))
DONE = reply("", ("finish_mission", {"outcome": "succeeded", "summary": "I'm in the kitchen."}))
GAVE_UP = reply("", ("finish_mission", {"outcome": "failed", "summary": "I couldn't get there."}))
LAPSED = (
    f"navigation to kitchen was cancelled ({LAPSE_REASONS['lapsed']}); the robot halted where it is"
)
SAID = (
    "I lost my safety link for a moment and stopped; it's back, so I'm carrying on to the kitchen."
)


def event(task_id: str, type_: str, seq: int, **payload: Any) -> TaskEvent:
    return TaskEvent(
        event_id=f"e-{task_id}-{seq}",
        task_id=task_id,
        server="navigation",
        tool="navigate_to",
        type=type_,  # type: ignore[arg-type]
        seq=seq,
        ts=time.time(),
        payload=payload,
    )


def lapsed(task_id: str, seq: int = 1) -> TaskEvent:
    return event(
        task_id, "task_failed", seq, error_code="CANCELLED", message=LAPSED, recoverable=True
    )


BASE_LOST = (
    "lost contact with the robot base on the way to kitchen: its navigation stack sent nothing "
    "for 3 s (stopped or restarting)"
)
SAID_BASE = (
    "I lost contact with my base for a moment and stopped; it's back, so I'm carrying on to the "
    "kitchen."
)


def base_lost(task_id: str, seq: int = 1) -> TaskEvent:
    return event(
        task_id,
        "task_failed",
        seq,
        error_code="BASE_UNAVAILABLE",
        message=BASE_LOST,
        recoverable=True,
    )


class Navigation:
    def __init__(self) -> None:
        self.drives = 0
        self.lock = "open"
        self.pose_stale = False
        self.poses_asked = 0
        self.refusals = 0  # the next calls refused NOT_SUPERVISED (the lease lapsed again)
        self.refusal = '{"error": "NOT_SUPERVISED", "detail": "the lease lapsed 0.3 s ago"}'

    def navigate_to(self, arguments: dict[str, Any]) -> str:
        if self.refusals:
            self.refusals -= 1
            raise ValueError(self.refusal)
        self.drives += 1
        return task_info(f"nav-{self.drives}")

    def get_pose(self, arguments: dict[str, Any]) -> dict[str, Any]:
        self.poses_asked += 1
        return {"x": 1.0, "y": 2.0, "stale": self.pose_stale, "moving": False}


async def supervised(tmp_path: Path, planner: FakeLLM) -> tuple[Harness, Navigation]:
    nav = Navigation()
    h = make_harness(tmp_path, planner, supervisor=(0.05, 0.5))
    h.tools.add("navigation.navigate_to", nav.navigate_to, location="string")
    h.tools.add("navigation.get_pose", nav.get_pose)
    h.tools.add(
        "navigation.supervise",
        lambda a: {
            "supervised": True,
            "latched": a["latched"],
            "lock": "locked" if a["latched"] else nav.lock,
        },
        holder="string",
    )
    assert h.supervisor is not None
    await h.supervisor.start()
    await async_wait_until(lambda: h.supervisor and h.supervisor.fresh("navigation"), 5, "lease")
    return h, nav


@pytest.fixture
async def drive(tmp_path: Path) -> Any:
    h, nav = await supervised(tmp_path, FakeLLM([PLAN, WAIT, DONE]))
    mission = await h.executor.start("drive to the kitchen")
    await async_wait_until(lambda: h.executor.run and h.executor.run.suspended, 5, "driving")
    yield h, nav, mission
    await h.executor.shutdown()
    assert h.supervisor is not None
    await h.supervisor.aclose()


async def test_a_drive_cancelled_by_a_lapse_is_reissued_and_the_mission_arrives(
    drive: Any,
) -> None:
    h, nav, mission = drive

    await h.executor.on_task_event(lapsed("nav-1"))
    await async_wait_until(lambda: nav.drives == 2, 5, "the drive re-issued")
    await async_wait_until(lambda: SAID in h.speech.spoken, 5, "said once")
    await h.executor.on_task_event(event("nav-2", "task_done", 1, result={"arrived": "kitchen"}))
    await h.executor.wait_idle(5)

    assert mission.state == "succeeded"
    assert h.tools.called("navigation.navigate_to") == [{"location": "kitchen"}] * 2
    assert h.speech.spoken.count(SAID) == 1
    assert [s.title for s in mission.steps] == ["Drive"]  # no extra step, no "Detour via"
    assert mission.steps[0].task_id == "nav-2"
    assert mission.steps[0].status == "succeeded"
    planner_saw = "\n".join(m.content for m in h.planner.requests[-1][0])
    assert "[task nav-1 navigation.navigate_to] done:" in planner_saw  # the task it waits on
    assert "supervision was lost" not in planner_saw
    assert h.executor.dispatcher.recovery.issued == {}  # nothing kept once the task ended


async def test_the_drive_waits_until_the_lock_is_open_again(drive: Any) -> None:
    h, nav, _ = drive
    nav.lock = "locked"
    assert h.supervisor is not None
    await async_wait_until(
        lambda: h.supervisor and not h.supervisor.lock_open("navigation"), 5, "locked"
    )

    await h.executor.on_task_event(lapsed("nav-1"))
    await async_wait_until(
        lambda: ((h.executor.run and h.executor.run.mission.steps[0].detail) or "").startswith(
            "safety link lost"
        ),
        5,
        "the step shows the wait",
    )
    assert nav.drives == 1  # not sent into a locked base
    nav.lock = "open"

    await async_wait_until(lambda: nav.drives == 2, 5, "re-issued once the lock opened")


async def test_a_step_that_keeps_lapsing_goes_to_the_planner_after_three_reissues(
    tmp_path: Path,
) -> None:
    h, nav = await supervised(tmp_path, FakeLLM([PLAN, WAIT, GAVE_UP]))
    try:
        mission = await h.executor.start("drive to the kitchen")
        await async_wait_until(lambda: h.executor.run and h.executor.run.suspended, 5, "driving")
        for n in range(1, MAX_RECOVERIES + 1):
            await h.executor.on_task_event(lapsed(f"nav-{n}", seq=n))
            await async_wait_until(lambda n=n: nav.drives == n + 1, 5, f"re-issued ({n})")

        await h.executor.on_task_event(lapsed(f"nav-{MAX_RECOVERIES + 1}", seq=9))
        await h.executor.wait_idle(5)
    finally:
        await h.executor.shutdown()
        assert h.supervisor is not None
        await h.supervisor.aclose()

    assert nav.drives == MAX_RECOVERIES + 1
    assert mission.state == "failed"
    assert h.speech.spoken.count(SAID) == 1  # told once, however often it was re-issued
    planner_saw = "\n".join(m.content for m in h.planner.requests[-1][0])
    assert "[task nav-1 navigation.navigate_to] failed CANCELLED" in planner_saw


SWEPT = (
    'Error executing tool navigate_to: {"error": "SAFETY_STOP_LATCHED", "detail": "the stop was '
    "cleared a moment ago: this server is cancelling every goal its base runs or holds before "
    'it moves again"}'
)


@pytest.mark.parametrize(
    ("refusal", "refusals"),
    [
        # the lease lapsed a moment before the call (a starved host)
        ('{"error": "NOT_SUPERVISED", "detail": "the lease lapsed 0.3 s ago"}', 2),
        # "continue" right after "clear stop": the server's sweep of old goals took the new one
        # too; the refusal as the MCP SDK sends it (its "Error executing tool" prefix)
        (SWEPT, 1),
    ],
)
async def test_a_drive_refused_for_a_moment_as_it_was_sent_is_sent_again_once_the_lock_opens(
    tmp_path: Path, refusal: str, refusals: int
) -> None:
    h, nav = await supervised(tmp_path, FakeLLM([PLAN, WAIT, DONE]))
    nav.refusal, nav.refusals = refusal, refusals
    try:
        mission = await h.executor.start("drive to the kitchen")
        await async_wait_until(lambda: nav.drives == 1, 5, "sent again after the refusals")
        await async_wait_until(lambda: h.executor.run and h.executor.run.suspended, 5, "driving")
        assert mission.state == "running"
        await h.executor.on_task_event(event("nav-1", "task_done", 1, result={"arrived": "x"}))
        await h.executor.wait_idle(5)
    finally:
        await h.executor.shutdown()
        assert h.supervisor is not None
        await h.supervisor.aclose()

    assert h.tools.called("navigation.navigate_to") == [{"location": "kitchen"}] * (refusals + 1)
    assert mission.state == "succeeded"
    planner_saw = "\n".join(m.content for m in h.planner.requests[1][0])
    assert "NOT_SUPERVISED" not in planner_saw
    assert "SAFETY_STOP_LATCHED" not in planner_saw


def test_only_a_momentary_refusal_is_sent_again() -> None:
    latched = '{"error": "SAFETY_STOP_LATCHED", "detail": "a software stop is latched"}'
    assert not refused_unsupervised(ToolOutcome(text=latched, is_error=True))
    lapsed = 'Error executing tool navigate_to: {"error": "NOT_SUPERVISED", "detail": "lapsed"}'
    assert refused_unsupervised(ToolOutcome(text=lapsed, is_error=True))
    assert not refused_unsupervised(ToolOutcome(text=lapsed, is_error=False))


async def test_a_refused_drive_is_not_sent_again_once_the_stop_latched(tmp_path: Path) -> None:
    nav = Navigation()
    h = make_harness(tmp_path, FakeLLM([PLAN, GAVE_UP]), supervisor=(0.05, 0.5))

    def refused_while_stopped(arguments: dict[str, Any]) -> str:
        h.latch.engage("operator", "person in the way")  # the stop came while the call was out
        nav.refusals = 1
        return nav.navigate_to(arguments)

    h.tools.add("navigation.navigate_to", refused_while_stopped, location="string")
    h.tools.add(
        "navigation.supervise",
        lambda a: {"supervised": True, "latched": a["latched"], "lock": "open"},
        holder="string",
    )
    assert h.supervisor is not None
    await h.supervisor.start()
    await async_wait_until(lambda: h.supervisor and h.supervisor.fresh("navigation"), 5, "lease")
    try:
        mission = await h.executor.start("drive to the kitchen")
        await h.executor.wait_idle(5)
    finally:
        await h.executor.shutdown()
        await h.supervisor.aclose()

    assert nav.drives == 0
    assert h.tools.called("navigation.navigate_to") == [{"location": "kitchen"}]
    assert mission.state != "succeeded"


async def test_no_recovery_while_the_stop_is_latched(drive: Any) -> None:
    h, nav, _ = drive
    h.latch.engage("operator", "person in the way")

    await h.executor.on_task_event(lapsed("nav-1"))
    await async_wait_until(lambda: len(h.planner.requests) >= 3, 5, "the planner told")

    assert nav.drives == 1
    assert SAID not in h.speech.spoken


async def test_no_recovery_after_an_operator_stop(drive: Any) -> None:
    h, nav, mission = drive
    await h.executor.on_user_turn("stop")
    await h.latch.clear("operator", "checked")

    await h.executor.on_task_event(lapsed("nav-1"))

    assert mission.state == "paused"
    assert nav.drives == 1
    assert SAID not in h.speech.spoken


def test_only_a_lapse_is_recovered_and_the_words_are_plain() -> None:
    assert is_lapse({"error_code": "CANCELLED", "message": LAPSED})
    assert is_lapse(
        {"error_code": "CANCELLED", "message": "the pick was cancelled (NOT_SUPERVISED)"}
    )
    latched = f"navigation to kitchen was cancelled ({LAPSE_REASONS['latched']})"
    assert not is_lapse({"error_code": "CANCELLED", "message": latched})
    assert not is_lapse({"error_code": "DOOR_CLOSED", "message": LAPSED})
    for call in [
        IssuedCall("navigation.navigate_to", {"location": "desk_alice"}, "s1"),
        IssuedCall("manipulation.pick", {"label": "yellow package", "mask_ref": "m-1"}, "s2"),
        IssuedCall("manipulation.place", {}, "s3"),
        IssuedCall("manipulation.release", {}, "s4"),
        IssuedCall("navigation.dock", {}, "s5"),
    ]:
        assert leaks(carrying_on(call)) == [], call


async def test_a_drive_whose_base_went_silent_for_a_moment_is_reissued_once_it_answers(
    drive: Any,
) -> None:
    h, nav, mission = drive
    nav.pose_stale = True

    await h.executor.on_task_event(base_lost("nav-1"))
    await async_wait_until(lambda: nav.poses_asked >= 2, 5, "the base asked for a fresh pose")
    assert nav.drives == 1  # not re-sent while the base is silent
    step = mission.steps[0]
    assert step.detail == "contact with the base lost for a moment: resuming"
    nav.pose_stale = False

    await async_wait_until(lambda: nav.drives == 2, 5, "re-issued once the base answered")
    await async_wait_until(lambda: SAID_BASE in h.speech.spoken, 5, "said once")
    await h.executor.on_task_event(event("nav-2", "task_done", 1, result={"arrived": "kitchen"}))
    await h.executor.wait_idle(5)

    assert mission.state == "succeeded"
    assert h.speech.spoken.count(SAID_BASE) == 1
    planner_saw = "\n".join(m.content for m in h.planner.requests[-1][0])
    assert "BASE_UNAVAILABLE" not in planner_saw


async def test_a_resend_refused_because_the_lease_lapsed_again_is_sent_once_more(
    drive: Any,
) -> None:
    h, nav, mission = drive
    nav.refusals = 1  # the host still catching up: the first resend finds the lease lapsed

    await h.executor.on_task_event(base_lost("nav-1"))
    await async_wait_until(lambda: nav.drives == 2, 5, "sent again after the refusal")
    await async_wait_until(lambda: SAID_BASE in h.speech.spoken, 5, "said once")

    assert nav.refusals == 0
    assert h.tools.called("navigation.navigate_to") == [{"location": "kitchen"}] * 3
    assert mission.state == "running"
    assert h.speech.spoken.count(SAID_BASE) == 1


async def test_a_base_that_stays_silent_fails_the_step_as_it_came(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(step_recovery, "BASE_BACK_WAIT_S", 0.3)
    h, nav = await supervised(tmp_path, FakeLLM([PLAN, WAIT, GAVE_UP]))
    nav.pose_stale = True
    try:
        mission = await h.executor.start("drive to the kitchen")
        await async_wait_until(lambda: h.executor.run and h.executor.run.suspended, 5, "driving")
        await h.executor.on_task_event(base_lost("nav-1"))
        await h.executor.wait_idle(5)
    finally:
        await h.executor.shutdown()
        assert h.supervisor is not None
        await h.supervisor.aclose()

    assert nav.drives == 1
    assert mission.state == "failed"
    assert SAID_BASE not in h.speech.spoken
    planner_saw = "\n".join(m.content for m in h.planner.requests[-1][0])
    assert "[task nav-1 navigation.navigate_to] failed BASE_UNAVAILABLE" in planner_saw


def test_which_failures_are_a_lost_link_and_what_a_fresh_pose_is() -> None:
    assert lost_link({"error_code": "CANCELLED", "message": LAPSED}) == "lease"
    assert lost_link({"error_code": "BASE_UNAVAILABLE", "recoverable": True}) == "base"
    assert lost_link({"error_code": "BASE_UNAVAILABLE", "recoverable": False}) is None
    assert lost_link({"error_code": "DOOR_CLOSED", "recoverable": True}) is None
    assert base_answers('{"stale": false, "x": 1.0}')
    assert not base_answers('{"stale": true}')
    assert not base_answers("{}")
    assert not base_answers("not json")
    call = IssuedCall("navigation.navigate_to", {"location": "kitchen"}, "s1")
    assert carrying_on(call, "base") == SAID_BASE
    assert leaks(carrying_on(call, "base")) == []
