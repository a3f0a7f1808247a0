"""The mission driver plays the user against a brain: REST turn, Socket.IO events, snapshot.

Here the brain is a small fake (Starlette + python-socketio on loopback) that answers the way
robot_voice_chat does; the real one is driven by tests/e2e and ``make demo``."""

from __future__ import annotations

import asyncio
import json
from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

import pytest
import socketio
import uvicorn
from starlette.applications import Starlette
from starlette.requests import Request
from starlette.responses import JSONResponse
from starlette.routing import Route

from robot_stack_testing import async_wait_until, free_tcp_port
from robot_stack_testing.mission_driver import (
    MissionDriver,
    MissionNotStartedError,
    MissionRecord,
    Narrator,
    stack_env,
)

MISSION_ID = "m-1"
DETECTION = {
    "label": "yellow package",
    "score": 0.9,
    "mask_ref": {"url": "http://127.0.0.1:9112/masks/find_object/1/0.png"},
}
SNAPSHOT = {
    "mission_id": MISSION_ID,
    "state": "succeeded",
    "events": [
        {
            "kind": "tool_result",
            "tool": "perception.wait_for_result",
            "is_error": False,
            "result": json.dumps({"detections": [DETECTION]}),
        },
        {"kind": "tool_result", "tool": "perception.get_latest", "is_error": True, "result": "x"},
        {"kind": "tool_result", "tool": "perception.get_latest", "result": "not json"},
    ],
}
PLAN = {
    "mission_id": MISSION_ID,
    "steps": [
        {"id": "s1", "title": "Drive", "tool": "navigation.navigate_to", "status": "succeeded"},
        {"id": "s2", "title": "Look", "tool": "perception.wait_for_result", "status": "succeeded"},
        {"id": "s3", "title": "Tell", "status": "pending"},
    ],
}


class FakeBrain:
    """Answers a turn by starting a mission (or not) and emitting what the UI would see."""

    def __init__(self, start_missions: bool = True) -> None:
        self.start_missions = start_missions
        self.sio = socketio.AsyncServer(async_mode="asgi")
        self.turns: list[str] = []
        routes = [
            Route("/api/chat", self.chat, methods=["POST"]),
            Route("/api/readyz", self.readyz),
            Route("/api/agent/missions/{mission_id}", self.mission),
        ]
        self.app = socketio.ASGIApp(self.sio, Starlette(routes=routes))

    async def readyz(self, request: Request) -> JSONResponse:
        return JSONResponse({"data": {"mcp_servers": {"navigation": "connected"}}})

    async def mission(self, request: Request) -> JSONResponse:
        if request.path_params["mission_id"] != MISSION_ID:
            return JSONResponse({"error": "unknown mission"}, status_code=404)
        return JSONResponse(SNAPSHOT)

    async def chat(self, request: Request) -> JSONResponse:
        text = (await request.json())["text"]
        self.turns.append(text)
        if not self.start_missions:
            return JSONResponse({"route": "chat", "reply": "hello"})
        asyncio.get_running_loop().call_later(0.05, lambda: asyncio.create_task(self._play(text)))
        return JSONResponse({"route": "mission_started", "mission_id": MISSION_ID})

    async def _play(self, text: str) -> None:
        emit = self.sio.emit
        await emit("chat_message", {"role": "user", "text": text})
        await emit("mission_started", {"mission_id": MISSION_ID, "instruction": text})
        await emit("chat_message", {"role": "assistant", "text": "On my way."})
        await emit("mission_plan", PLAN)
        await emit("mission_event", {"kind": "task_event", "text": "[task nav-1] done"})
        await emit("mission_event", {"kind": "say", "text": "shown as speak"})
        await emit("speak", {"text": "I found it."})
        await emit("mission_finished", {"mission_id": MISSION_ID, "outcome": "succeeded"})


async def serve(brain: FakeBrain) -> AsyncIterator[str]:
    port = free_tcp_port()
    server = uvicorn.Server(
        uvicorn.Config(brain.app, host="127.0.0.1", port=port, log_level="warning")
    )
    serving = asyncio.create_task(server.serve())
    await async_wait_until(lambda: server.started, 10, "fake brain serving")
    try:
        yield f"http://127.0.0.1:{port}"
    finally:
        server.should_exit = True
        await asyncio.wait_for(serving, 10)


@pytest.fixture
async def brain_url() -> AsyncIterator[str]:
    async for url in serve(FakeBrain()):
        yield url


async def test_a_mission_is_driven_to_its_end_and_narrated(brain_url: str) -> None:
    lines: list[str] = []
    async with MissionDriver(brain_url, Narrator(lines.append)) as user:
        states = await user.wait_servers_connected(5.0)
        record = await user.run_mission("fetch the package", timeout_s=10.0)

    assert states == {"navigation": "connected"}
    assert record.reply["mission_id"] == record.mission_id == MISSION_ID
    assert record.outcome == "succeeded"
    assert record.snapshot["state"] == "succeeded"
    assert record.event_lines("task_event") == ["[task nav-1] done"]
    text = "\n".join(lines)
    assert "user said : 'fetch the package'" in text
    assert "robot said: 'On my way.'" in text
    assert "robot says : 'I found it.'" in text
    assert "step s2 succeeded" in text
    assert "shown as speak" not in text  # say events are narrated once, as speak
    assert "mission succeeded" in text
    await async_wait_until(lambda: "vision found" in "\n".join(lines), 5.0, "findings narrated")


async def test_a_turn_that_starts_no_mission_is_reported() -> None:
    async for url in serve(FakeBrain(start_missions=False)):
        async with MissionDriver(url) as user:
            with pytest.raises(MissionNotStartedError, match="did not start a mission"):
                await user.run_mission("hello", timeout_s=1.0)


def test_findings_come_from_successful_perception_answers_only() -> None:
    record = MissionRecord(snapshot=SNAPSHOT)

    [finding] = record.findings()
    assert (finding.label, finding.score) == ("yellow package", 0.9)
    assert finding.mask_url.endswith("/masks/find_object/1/0.png")
    assert len(record.tool_results("perception.get_latest")) == 2
    assert record.outcome is None


def test_a_replanned_plan_is_narrated_as_such() -> None:
    lines: list[str] = []
    narrator = Narrator(lines.append)
    narrator.event("mission_plan", PLAN)
    narrator.event("mission_plan", {**PLAN, "steps": [*PLAN["steps"], {"id": "s4", "title": "x"}]})
    narrator.event("unknown_event", {"x": 1})

    assert any(line.endswith("] plan:") for line in lines)
    assert any("plan updated (replanned)" in line for line in lines)


def test_progress_of_a_running_step_is_throttled_but_status_changes_always_show() -> None:
    lines: list[str] = []
    narrator = Narrator(lines.append, progress_every_s=3600.0)

    def plan(status: str, detail: str) -> dict[str, Any]:
        return {"steps": [{"id": "s1", "title": "Drive", "status": status, "detail": detail}]}

    for percent in (10, 20, 30):
        narrator.event("mission_plan", plan("running", f"ETA · {percent} %"))
    narrator.event("mission_plan", plan("succeeded", "done"))

    steps = [line.split("] ", 1)[1] for line in lines if "step s1" in line]
    assert steps == ["step s1 running — ETA · 10 %", "step s1 succeeded — done"]


def test_the_stack_environment_shares_one_secret_and_stays_on_loopback() -> None:
    env = stack_env("s3cret")

    assert env["RVC_EVENT_SECRET"] == env["NAV_EVENT_SECRET"] == env["PERCEPTION_EVENT_SECRET"]
    assert env["MANIP_EVENT_SECRET"] == env["RVC_EVENT_SECRET"]
    assert env["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "LOCALHOST"


def _scene(scenes: Path, name: str, annotations: list[dict[str, Any]]) -> None:
    (scenes / f"{name}.json").write_text(json.dumps({"annotations": annotations}))
    (scenes / f"{name}.png").write_bytes(b"png")


async def test_every_sentence_the_robot_said_is_checked_when_the_driver_closes(
    brain_url: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    checked: list[str] = []

    def check(sentence: str) -> list[str]:
        checked.append(sentence)
        return ["leak"] if "I found it" in sentence else []

    monkeypatch.setattr(MissionDriver, "words_check", staticmethod(check))
    with pytest.raises(AssertionError, match="the robot's words leak"):
        async with MissionDriver(brain_url) as user:
            record = await user.run_mission("fetch the package", timeout_s=10.0)
    assert "On my way." in record.robot_words()
    assert "I found it." in checked
    assert "[task nav-1] done" not in checked  # task events are not the robot's words
