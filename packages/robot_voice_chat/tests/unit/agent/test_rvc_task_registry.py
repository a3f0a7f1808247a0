"""Task registry (spec §5.4): recognition, formatting, reconciliation, orphans."""

from __future__ import annotations

import json
import time
from pathlib import Path

from robot_mcp_kit.models import TaskEvent
from robot_stack_testing import async_wait_until
from robot_stack_testing.brain.harness import make_harness
from robot_voice_chat.agent.task_registry import (
    TaskHandle,
    TaskRegistry,
    format_event,
    parse_task_info,
    progress_detail,
    running_task_ids,
)
from robot_voice_chat.services.llm.fake import FakeLLM, reply


def ev(type_: str, task_id: str = "nav-1", **payload: object) -> TaskEvent:
    return TaskEvent(
        task_id=task_id,
        server="navigation",
        tool="navigate_to",
        type=type_,
        seq=0,
        ts=time.time(),
        payload=payload,
    )


def test_only_running_task_info_json_is_recognised_as_an_async_task() -> None:
    assert parse_task_info(json.dumps({"task_id": "t1", "state": "running"})) is not None
    assert parse_task_info(json.dumps({"task_id": "t1"})) is not None
    assert parse_task_info(json.dumps({"task_id": "t1", "state": "succeeded"})) is None
    assert parse_task_info(json.dumps({"result": 3})) is None
    assert parse_task_info("plain text") is None


def test_events_are_formatted_compactly_and_progress_is_kept_out() -> None:
    label = "[task nav-7f3a navigation.navigate_to]"
    assert format_event(ev("progress", eta_s=3), label) is None
    fired = ev("trigger_fired", eta_s=9.4, trigger={"type": "eta_below", "seconds": 10})
    assert format_event(fired, label) == f"{label} trigger_fired: eta_below 10 (eta 9.4s)"
    failed = ev("task_failed", error_code="DOOR_CLOSED", message="Closed.", recoverable=False)
    assert format_event(failed, label) == f"{label} failed DOOR_CLOSED (not recoverable): Closed."
    assert "watch_event" in (format_event(ev("watch_event", value=True), label) or "")
    assert progress_detail({"eta_s": 9.2, "pct": 82.0}) == "ETA 9 s · 82 %"
    assert progress_detail({"progress": 0.5}) == "50 %"


def test_registry_retires_handles_on_terminal_events_and_keeps_latest_progress() -> None:
    registry = TaskRegistry()
    registry.register(TaskHandle("nav-1", "navigation", "navigate_to", "s1", "m-1"))
    registry.resolve(ev("progress", eta_s=4, pct=50))
    assert "latest progress: ETA 4 s · 50 %" in registry.snapshot("m-1")
    assert registry.resolve(ev("task_done")) is not None
    assert registry.live() == []
    assert registry.resolve(ev("task_done")) is None
    assert running_task_ids(
        json.dumps([{"task_id": "a"}, {"task_id": "b", "state": "failed"}])
    ) == {"a"}
    assert running_task_ids("nope") is None


async def test_reconciliation_fails_tasks_the_restarted_server_forgot(tmp_path: Path) -> None:
    planner = FakeLLM(
        [
            reply("", ("navigation.navigate_to", {"location": "lab"})),
            reply("", ("wait_for_events", {"reason": "x"})),
            reply("", ("finish_mission", {"outcome": "failed", "summary": "server restarted"})),
        ]
    )
    h = make_harness(tmp_path, planner)
    h.tools.add_connect_listener(h.executor.reconcile)  # what Container.start wires
    await h.executor.start("go to the lab")
    await async_wait_until(lambda: h.executor.run and h.executor.run.suspended, 5, "suspended")

    await h.tools.reconnected("navigation")  # the list_tasks answer no longer has nav-1
    await h.executor.wait_idle(5)

    text = "\n".join(m.content for m in planner.requests[-1][0])
    assert "failed SERVER_RESTARTED (recoverable)" in text


async def test_reconciliation_when_idle_cancels_orphan_running_tasks(tmp_path: Path) -> None:
    h = make_harness(tmp_path, FakeLLM([]))
    h.tools.add("navigation.list_tasks", lambda a: [{"task_id": "old-1", "state": "running"}])
    await h.executor.reconcile("navigation")
    assert h.tools.called("navigation.cancel_task") == [{"task_id": "old-1"}]


async def test_events_for_unknown_tasks_are_orphans(tmp_path: Path) -> None:
    h = make_harness(tmp_path, FakeLLM([]))
    assert await h.executor.on_task_event(ev("task_done", task_id="ghost")) is False


async def test_an_event_that_overtakes_its_tool_result_is_replayed_on_registration(
    tmp_path: Path,
) -> None:
    planner = FakeLLM(
        [
            reply("", ("set_plan", {"steps": [{"id": "s1", "title": "Drive"}]})),
            reply("", ("navigation.navigate_to", {"step_id": "s1", "location": "lab"})),
            reply("", ("finish_mission", {"outcome": "succeeded", "summary": "ok"})),
        ]
    )
    h = make_harness(tmp_path, planner)
    assert await h.executor.on_task_event(ev("task_done")) is False  # arrives first
    mission = await h.executor.start("go")
    await h.executor.wait_idle(5)
    assert mission.steps[0].status == "succeeded"
