"""REST for operator control: /api/agent/approvals, /api/safety (+ readyz fields)."""

from __future__ import annotations

from pathlib import Path

import httpx

from robot_stack_testing import async_wait_until
from robot_stack_testing.brain.life import brain_life, fake_servers
from robot_voice_chat.api.app import create_app
from robot_voice_chat.api.container import Container
from robot_voice_chat.services.emitter.base import FakeEventEmitter
from robot_voice_chat.services.llm.fake import FakeLLM, reply
from robot_voice_chat.services.tools.fake import FakeToolBackend
from robot_voice_chat.socket_events import ChatMessage, SafetyState

PLAN = reply(
    "",
    ("set_plan", {"steps": [{"id": "s1", "title": "Drive", "tool": "navigation.navigate_to"}]}),
    ("navigation.navigate_to", {"step_id": "s1", "location": "kitchen"}),
)
WAIT = reply("", ("wait_for_events", {"reason": "driving"}))


def brain(tmp_path: Path, planner: FakeLLM) -> tuple[Container, FakeToolBackend]:
    policy = tmp_path / "policy.yaml"
    policy.write_text("version: 3\ntools:\n  navigation.navigate_to: confirm\n")
    container = brain_life(
        planner,
        agent={"memory_server": "", "data_dir": str(tmp_path / "data")},
        control={"policy_file": str(policy)},
    )
    return container, fake_servers(container)


async def test_approve_over_rest_drives_once_and_a_replay_is_refused(tmp_path: Path) -> None:
    container, tools = brain(tmp_path, FakeLLM([PLAN, WAIT]))
    app = create_app(container, manage_lifecycle=False)
    async with httpx.AsyncClient(
        transport=httpx.ASGITransport(app), base_url="http://127.0.0.1"
    ) as c:
        mission = await container.executor.start("go to the kitchen")
        pending: list[dict[str, object]] = []

        async def listed() -> bool:
            pending[:] = (await c.get("/api/agent/approvals")).json()
            return bool(pending)

        await async_wait_until(listed, 5, "a pending approval")
        approval_id = str(pending[0]["approval_id"])
        assert pending[0]["mission_id"] == mission.id
        assert pending[0]["arguments"] == {"location": "kitchen"}
        assert mission.state == "awaiting_approval"

        bad = await c.post(f"/api/agent/approvals/{approval_id}", json={"decision": "maybe"})
        ok = await c.post(f"/api/agent/approvals/{approval_id}", json={"decision": "approve"})
        replay = await c.post(f"/api/agent/approvals/{approval_id}", json={"decision": "approve"})
        unknown = await c.post("/api/agent/approvals/ap-nope", json={"decision": "approve"})
        await async_wait_until(lambda: tools.called("navigation.navigate_to"), 5, "drive")
        ready = (await c.get("/api/readyz")).json()["data"]

    assert bad.status_code == 422
    assert ok.status_code == 200
    assert ok.json()["decision"] == "approve"
    assert replay.status_code == 409
    assert unknown.status_code == 404
    assert tools.called("navigation.navigate_to") == [{"location": "kitchen"}]
    assert ready["policy"]["version"] == 3
    assert len(ready["policy"]["digest"]) == 64
    await container.executor.shutdown()


async def test_safety_routes_report_stop_and_clear(tmp_path: Path) -> None:
    container, tools = brain(tmp_path, FakeLLM([]))
    app = create_app(container, manage_lifecycle=False)
    async with httpx.AsyncClient(
        transport=httpx.ASGITransport(app), base_url="http://127.0.0.1"
    ) as c:
        before = (await c.get("/api/safety")).json()
        stopped = (await c.post("/api/safety/stop", json={"reason": "person in the way"})).json()
        ready = (await c.get("/api/readyz")).json()["data"]["safety"]
        no_reason = await c.post("/api/safety/clear", json={})
        cleared = await c.post("/api/safety/clear", json={"reason": "corridor checked"})
        again = await c.post("/api/safety/clear", json={"reason": "corridor checked"})

    assert before == {"latched": False, "since": None, "by": None, "reason": None, "alarms": []}
    assert stopped["latched"] is True
    assert stopped["reason"] == "person in the way"
    assert ready == stopped
    assert tools.called("navigation.stop_navigation") == [{}]
    assert no_reason.status_code == 422
    assert cleared.json()["latched"] is False
    assert again.status_code == 409
    journal = (tmp_path / "data" / "safety" / "latch.journal").read_text()
    assert "corridor checked" in journal


async def test_safety_names_the_alarm_that_latched_the_stop(tmp_path: Path) -> None:
    """Issue 35: a motion server's alarm latches the stop; /api/safety and readyz say why in
    words (the reason) and which alarm (its code and the server's own sentence)."""
    ui = FakeEventEmitter()
    container = brain_life(
        FakeLLM([]), ui, agent={"memory_server": "", "data_dir": str(tmp_path / "data")}
    )
    tools = fake_servers(container)
    alarm = {"code": "LOCK_TOPIC_SHARED", "detail": "Another node publishes the lock.", "at": 5.0}
    tools.add(
        "navigation.supervise",
        lambda a: {
            "supervised": True,
            "latched": a["latched"],
            "lock": "locked",
            "alarms": [alarm],
        },
        holder="string",
        latched="boolean",
    )
    app = create_app(container, manage_lifecycle=False)
    assert container.supervisor is not None
    await container.supervisor.start()
    try:
        async with httpx.AsyncClient(
            transport=httpx.ASGITransport(app), base_url="http://127.0.0.1"
        ) as c:
            await async_wait_until(lambda: container.executor.latch.latched, 5, "the latch")
            await async_wait_until(lambda: told(ui), 5, "the operator told")
            await async_wait_until(lambda: safety_events(ui), 5, "the latch shown")
            safety = (await c.get("/api/safety")).json()
            ready = (await c.get("/api/readyz")).json()["data"]
    finally:
        await container.supervisor.aclose()

    assert safety["latched"] is True
    assert safety["by"] == "the robot's supervision"
    assert safety["reason"] == "another program is publishing on the motion lock of my navigation"
    assert safety["alarms"] == [{"server": "navigation", **alarm}]
    assert ready["safety"]["alarms"] == safety["alarms"]
    assert ready["supervision"]["alarms"] == safety["alarms"]
    said = told(ui)
    assert said == [
        "Someone else tried to move me, so I stopped. Another program is publishing on the "
        "motion lock of my navigation. Check the robot's computer, then clear the stop."
    ]  # once, though every renewal since carried the alarm
    assert tools.called("navigation.stop_navigation") == [{}]  # the stop reached the base
    latest = safety_events(ui)[-1]
    assert latest.latched
    assert [a.code for a in latest.alarms] == ["LOCK_TOPIC_SHARED"]


def told(ui: FakeEventEmitter) -> list[str]:
    return [
        e.text
        for e in ui.events
        if isinstance(e, ChatMessage) and e.role == "assistant" and "Someone else" in e.text
    ]


def safety_events(ui: FakeEventEmitter) -> list[SafetyState]:
    return [e for e in ui.events if isinstance(e, SafetyState)]
