"""A mission a crashed process life left live (issue 23 item 3) is closed at the next
start-up: failed, "interrupted by a restart", steps resolved, trace + UI told; the tasks it
owned are cancelled at their servers and their late events acknowledged, not taken as live.
(The kill -9 of a real brain process is tests/e2e/test_brain_crash_recovery.py.)"""

from __future__ import annotations

import json
from pathlib import Path

import httpx

from robot_mcp_kit.models import TaskEvent
from robot_stack_testing import async_wait_until
from robot_stack_testing.brain.life import brain_life, fake_servers
from robot_voice_chat.api.app import create_app
from robot_voice_chat.api.container import Container
from robot_voice_chat.services.emitter.base import FakeEventEmitter
from robot_voice_chat.services.llm.base import LLMResponse
from robot_voice_chat.services.llm.fake import FakeLLM, reply
from robot_voice_chat.services.speech.fake import FakeSpeechOutput
from robot_voice_chat.socket_events import MissionFinished, MissionPlan


def brain(tmp_path: Path, planner: FakeLLM, ui: FakeEventEmitter | None = None) -> Container:
    """One process life of the brain: fresh in-memory state, the same data dir."""
    return brain_life(planner, ui)


DRIVE: list[LLMResponse | Exception] = [
    reply(
        "",
        ("set_plan", {"steps": [{"id": "s1", "title": "Drive"}, {"id": "s2", "title": "Tell"}]}),
    ),
    reply("", ("navigation.navigate_to", {"step_id": "s1", "location": "kitchen"})),
    reply("", ("wait_for_events", {"reason": "driving"})),
]


async def crash_mid_drive(tmp_path: Path) -> tuple[Container, str]:
    """A brain life that dies like kill -9 mid-drive: nothing written after the drive began."""
    first = brain(tmp_path, FakeLLM(DRIVE))
    mission = await first.executor.start("go to the kitchen")
    await async_wait_until(
        lambda: first.executor.registry.live(mission.id), 5, "the drive registered"
    )
    run = first.executor.run
    assert run is not None
    await async_wait_until(lambda: run.suspended, 5, "waiting for the drive")
    first.executor.archive = first.executor.output.archive = None  # the process is gone
    first.executor.trace.record = lambda *a, **k: None  # type: ignore[method-assign]
    return first, mission.id


async def test_a_mission_left_running_by_a_crash_is_closed_at_start_up(tmp_path: Path) -> None:
    first, mission_id = await crash_mid_drive(tmp_path)
    ui = FakeEventEmitter()
    second = brain(tmp_path, FakeLLM([]), ui)
    fake_servers(second).add(
        "navigation.list_tasks",
        lambda a: {"tasks": [{"task_id": "nav-1", "state": "running"}]},
        states="array",
    )
    await second.start()
    app = create_app(second, manage_lifecycle=False)
    async with httpx.AsyncClient(
        transport=httpx.ASGITransport(app), base_url="http://127.0.0.1"
    ) as c:
        snap = (await c.get(f"/api/agent/missions/{mission_id}")).json()
        listing = (await c.get("/api/agent/missions")).json()
    try:
        assert snap["state"] == "failed"
        assert "interrupted by a restart" in snap["summary"]
        assert [(s["id"], s["status"], s["detail"]) for s in snap["steps"]] == [
            ("s1", "failed", "interrupted by a restart"),
            ("s2", "skipped", "never run"),
        ]
        assert snap["log"][-1]["kind"] == "say"
        assert "interrupted by a restart" in snap["log"][-1]["text"]
        assert listing["active"] is None
        assert listing["missions"][0]["state"] == "failed"
        # the UI is told, the trace closed
        events = ui.events
        assert any(isinstance(e, MissionFinished) and e.mission_id == mission_id for e in events)
        assert any(isinstance(e, MissionPlan) and e.state == "failed" for e in events)
        final = [r for r in await second.trace.read(mission_id) if r["kind"] == "final"]
        assert final[-1]["reason"] == "interrupted by a restart"
        assert final[-1]["tasks"] == ["nav-1"]

        # the task it owned is cancelled when navigation (re)connects, also mid-mission
        second.executor.run = first.executor.run  # any live mission: still cancelled
        await second.executor.reconcile("navigation")
        assert fake_servers(second).called("navigation.cancel_task") == [{"task_id": "nav-1"}]
        second.executor.run = None
        # its late events are acknowledged (False = orphan, 200) and not kept for replay
        late = TaskEvent(
            task_id="nav-1",
            server="navigation",
            tool="navigate_to",
            type="task_failed",
            seq=3,
            ts=0.0,
            payload={"error_code": "CANCELLED", "message": "cancelled"},
        )
        assert await second.executor.on_task_event(late) is False
        assert not second.executor.dispatcher.early_events
        # a restart later, nothing is left to close
        again = brain(tmp_path, FakeLLM([]))
        await again.executor.recover()
        assert again.executor.dispatcher.interrupted == set()
        assert json.dumps(snap)  # served as JSON
    finally:
        await second.stop()
        run = first.executor.run
        if run is not None and run.task is not None:
            run.task.cancel()


async def test_a_restart_after_the_drive_had_finished_claims_no_cancelled_tasks(
    tmp_path: Path,
) -> None:
    """Issue 31: "its tasks were cancelled" was said although the drive had finished."""
    first, mission_id = await crash_mid_drive(tmp_path)
    second = brain(tmp_path, FakeLLM([]))
    servers = fake_servers(second)
    servers.add("navigation.list_tasks", lambda a: {"tasks": []}, states="array")  # it arrived
    await second.start()
    try:
        closed = await second.executor.find_mission(mission_id)
        assert closed is not None
        assert closed.state == "failed"
        assert "cancel" not in closed.summary
        assert "stopped" not in closed.summary
        await second.executor.reconcile("navigation")
        assert servers.called("navigation.cancel_task") == []
        speech = second.adapters.speech_output
        assert isinstance(speech, FakeSpeechOutput)
        assert not any("cancel" in s or "stopped" in s for s in speech.spoken), speech.spoken

        # a drive still running at the restart is stopped, and that is said
        servers.add(
            "navigation.list_tasks",
            lambda a: {"tasks": [{"task_id": "nav-1", "state": "running"}]},
            states="array",
        )
        await second.executor.reconcile("navigation")
        assert servers.called("navigation.cancel_task") == [{"task_id": "nav-1"}]
        assert any("stopped the drive" in s for s in speech.spoken), speech.spoken
    finally:
        await second.stop()
        run = first.executor.run
        if run is not None and run.task is not None:
            run.task.cancel()
