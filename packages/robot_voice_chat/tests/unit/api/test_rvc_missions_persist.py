"""Missions persist across restarts (issue 13 item 20): SQLite in the brain's data dir."""

from __future__ import annotations

from pathlib import Path

import httpx
import pytest

from robot_stack_testing.brain.life import brain_life
from robot_voice_chat.api.app import create_app
from robot_voice_chat.api.container import Container
from robot_voice_chat.composition import compose_config
from robot_voice_chat.services.llm.base import Usage
from robot_voice_chat.services.llm.fake import FakeLLM, reply
from robot_voice_chat.settings import AgentConfig, data_dir
from robot_voice_chat.socket_events import MissionEventLine

PLAN = [
    reply(
        "",
        ("set_plan", {"steps": [{"id": "s1", "title": "Look"}, {"id": "s2", "title": "Tell"}]}),
    ),
    reply("", ("perception.prewarm", {"step_id": "s1", "query": "mug"})),
    reply(
        "",
        ("say", {"text": "I see a mug."}),
        ("mark_step", {"step_id": "s2", "status": "succeeded"}),
    ),
    reply("", ("finish_mission", {"outcome": "succeeded", "summary": "Found the mug."})),
]


def brain(tmp_path: Path, planner: FakeLLM) -> Container:
    """One process life of the brain: fresh in-memory state, same data dir."""
    return brain_life(planner)


async def test_a_mission_and_its_log_are_served_after_a_restart(tmp_path: Path) -> None:
    first = brain(tmp_path, FakeLLM(PLAN))
    mission = await first.executor.start("find the mug")
    await first.executor.wait_idle(5)
    await first.stop()

    second = brain(tmp_path, FakeLLM([]))
    app = create_app(second, manage_lifecycle=False)
    async with httpx.AsyncClient(
        transport=httpx.ASGITransport(app), base_url="http://127.0.0.1"
    ) as c:
        snap = (await c.get(f"/api/agent/missions/{mission.id}")).json()
        listing = (await c.get("/api/agent/missions")).json()

    assert snap["state"] == "succeeded"
    assert snap["summary"] == "Found the mug."
    assert [(s["id"], s["status"]) for s in snap["steps"]] == [
        ("s1", "succeeded"),
        ("s2", "succeeded"),
    ]
    lines = [MissionEventLine.model_validate(e) for e in snap["log"]]
    assert [(e.kind, e.text) for e in lines] == [
        ("tool_call", 'perception.prewarm({"query":"mug"})'),
        ("say", "I see a mug."),
    ]
    assert all(e.mission_id == mission.id for e in lines)
    assert [e["tool"] for e in snap["events"] if e["kind"] == "tool_result"][1] == (
        "perception.prewarm"
    )  # the trace records survive too
    assert listing["missions"][0]["id"] == mission.id
    assert listing["missions"][0]["state"] == "succeeded"


async def test_say_lines_and_step_timings_are_traced(tmp_path: Path) -> None:
    container = brain(tmp_path, FakeLLM(PLAN))
    mission = await container.executor.start("find the mug")
    await container.executor.wait_idle(5)
    records = await container.trace.read(mission.id)
    assert [r["text"] for r in records if r["kind"] == "say"] == ["I see a mug."]
    final = [r for r in records if r["kind"] == "plan"][-1]["timings"]
    assert [t["id"] for t in final] == ["s1", "s2"]
    assert all(t["started_at"] and t["ended_at"] and t["duration_ms"] >= 0 for t in final[:1])
    assert final[1]["ended_at"] is not None


def test_state_lives_in_the_data_dir_never_the_working_directory(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("RVC_DATA_DIR", str(tmp_path / "state"))
    config = compose_config("dev")
    assert data_dir(config.agent) == tmp_path / "state"
    monkeypatch.delenv("RVC_DATA_DIR")
    default = data_dir(AgentConfig())
    assert default.is_absolute()
    assert "robot-voice-chat" in default.parts
    assert tmp_path not in default.parents


async def test_a_missions_token_and_cost_totals_survive_a_restart(tmp_path: Path) -> None:
    costly = [
        r.model_copy(update={"usage": Usage(input_tokens=100, output_tokens=10, cost_usd=0.01)})
        for r in PLAN
    ]
    first = brain(tmp_path, FakeLLM(costly))
    mission = await first.executor.start("find the mug")
    await first.executor.wait_idle(5)
    await first.stop()

    second = brain(tmp_path, FakeLLM([]))
    app = create_app(second, manage_lifecycle=False)
    async with httpx.AsyncClient(
        transport=httpx.ASGITransport(app), base_url="http://127.0.0.1"
    ) as c:
        snap = (await c.get(f"/api/agent/missions/{mission.id}")).json()

    assert snap["usage"]["input_tokens"] == 400
    assert snap["usage"]["output_tokens"] == 40
    assert snap["usage"]["cost_usd"] == pytest.approx(0.04)
