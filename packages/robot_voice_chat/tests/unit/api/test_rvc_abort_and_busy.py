"""Abort and stop are always heard (issue 39 item 4): "abort" / "cancel" end a running mission
at once — its drive stops in the simulated office, the mission ends cancelled — and a burst of
messages while a mission starts is answered on screen each time but said aloud once."""

from __future__ import annotations

import asyncio
from collections.abc import AsyncIterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import httpx
import pytest

from robot_stack_testing import async_wait_until
from robot_stack_testing.brain.harness import make_harness, nav_servers
from robot_stack_testing.brain.life import brain_life
from robot_stack_testing.brain.office_world import OfficeWorld
from robot_voice_chat.agent.abort import is_abort
from robot_voice_chat.agent.trace import TraceRecorder
from robot_voice_chat.api.app import create_app
from robot_voice_chat.api.container import Container
from robot_voice_chat.control.approvals import ApprovalBroker
from robot_voice_chat.control.policy import ToolPolicy
from robot_voice_chat.robot_words import check_robot_words
from robot_voice_chat.services.emitter.base import FakeEventEmitter
from robot_voice_chat.services.llm.fake import FakeLLM, reply
from robot_voice_chat.services.llm.rules.chat import RulesChat
from robot_voice_chat.services.llm.rules.planner import RulesPlanner
from robot_voice_chat.services.speech.fake import FakeSpeechOutput
from robot_voice_chat.services.tools.fake import FakeToolBackend
from robot_voice_chat.socket_events import (
    ApprovalRequested,
    ApprovalResolved,
    ChatMessage,
    MissionFinished,
)

PLACES = ["kitchen", "reception", "mailroom", "corridor_b", "dock"]


@dataclass
class Brain:
    container: Container
    world: OfficeWorld
    client: httpx.AsyncClient
    emitter: FakeEventEmitter
    speech: FakeSpeechOutput

    async def chat(self, text: str) -> dict[str, Any]:
        response = await self.client.post("/api/chat", json={"text": text})
        assert response.status_code == 200, response.text
        body: dict[str, Any] = response.json()
        return body


@pytest.fixture
async def brain(tmp_path: Path) -> AsyncIterator[Brain]:
    tools = FakeToolBackend(nav_servers())
    world = OfficeWorld(tools, drive_s=30.0)  # drives outlast the test: only a cancel ends one
    emitter = FakeEventEmitter()
    container = brain_life(
        RulesPlanner(prewarm=False),
        emitter,
        tools=tools,
        chat=RulesChat(),
        llm={"_target_": "rules"},
    )
    speech = container.adapters.speech_output
    assert isinstance(speech, FakeSpeechOutput)
    world.deliver = container.executor.on_task_event
    app = create_app(container, manage_lifecycle=False)
    transport = httpx.ASGITransport(app)
    async with httpx.AsyncClient(transport=transport, base_url="http://127.0.0.1") as client:
        try:
            yield Brain(container, world, client, emitter, speech)
        finally:
            await container.stop()
            if world.driving is not None:
                world.driving.cancel()


@pytest.mark.parametrize("word", ["abort", "cancel", "Cancel the mission please", "never mind"])
async def test_abort_during_a_drive_stops_the_drive_and_ends_the_mission(
    brain: Brain, word: str
) -> None:
    """Five "abort" messages got "I'm busy … your message went to it" and the drive went on."""
    assert (await brain.chat("go to the kitchen"))["route"] == "mission_started"
    executor = brain.container.executor
    await async_wait_until(lambda: executor.registry.live(), 10, "driving")
    mission = executor.active
    assert mission is not None
    drive = brain.world.driving
    assert drive is not None
    assert not drive.done()

    answer = await brain.chat(word)

    assert answer["route"] == "mission", answer
    assert "busy" not in answer["reply"], answer
    # the world: the drive is cancelled on the base, the robot never got to the kitchen
    assert brain.world.tasks["nav-1"]["state"] == "cancelled"
    await async_wait_until(drive.done, 5, "the drive to end")
    assert brain.world.at == "dock"
    finished = await async_wait_until(
        lambda: [e for e in brain.emitter.events if isinstance(e, MissionFinished)],
        10,
        "the mission to end",
    )
    assert finished[0].outcome == "cancelled"
    assert mission.state == "cancelled"
    assert "aborted" in mission.summary
    assert executor.active is None
    assert brain.world.tools.called("navigation.cancel_task") == [{"task_id": "nav-1"}]
    assert not brain.container.executor.latch.latched  # an abort latches no stop
    assert not check_robot_words([answer["reply"], mission.summary, *brain.speech.spoken])
    # the next request is a new mission, not news for the aborted one
    assert (await brain.chat("go to the reception"))["route"] == "mission_started"


async def test_a_burst_while_a_mission_starts_is_said_aloud_once(brain: Brain) -> None:
    """20 concurrent messages: one mission; the busy reply shown to each, spoken once."""
    texts = [f"go to the {PLACES[i % len(PLACES)]}" for i in range(20)]
    answers = await asyncio.gather(*(brain.chat(t) for t in texts))

    assert len([a for a in answers if a["route"] == "mission_started"]) == 1
    busy = [a["reply"] for a in answers if "busy" in a["reply"]]
    assert busy, answers
    shown = [
        e.text
        for e in brain.emitter.events
        if isinstance(e, ChatMessage) and e.role == "assistant" and "busy" in e.text
    ]
    assert len(shown) == len(busy)  # every turn still gets its answer on screen
    spoken = [s for s in brain.speech.spoken if "busy" in s]
    assert len(spoken) == 1, spoken
    assert "Say stop if you want me to halt" not in " ".join(brain.speech.spoken)
    for said in busy:
        assert said.count(". ") == 0, said  # one sentence
        assert said.endswith("."), said
        assert "abort" in said, said
    assert not check_robot_words(busy + brain.speech.spoken)


@pytest.mark.parametrize(
    ("text", "aborts"),
    [
        ("abort", True),
        ("Abort!", True),
        ("cancel that", True),
        ("please cancel the mission", True),
        ("never mind", True),
        ("forget it", True),
        ("don't cancel", False),
        ("do not abort the mission", False),
        ("never mind the door, go on", False),
        ("what are you doing?", False),
        ("cancelled flights", False),
    ],
)
def test_what_counts_as_an_abort(text: str, aborts: bool) -> None:
    assert is_abort(text) is aborts


async def test_cancel_is_heard_over_a_pending_approval(tmp_path: Path) -> None:
    """Was: "cancel" answered "I'm waiting for your yes or no …" and the mission waited on."""
    (tmp_path / "policy.yaml").write_text(
        "version: 1\ntools:\n  navigation.navigate_to: {decision: confirm, reason: drive}\n"
    )
    emitter = FakeEventEmitter()
    trace = TraceRecorder(tmp_path / "missions")
    broker = ApprovalBroker(emitter=emitter, trace=trace, audit_path=tmp_path / "a.jsonl")
    plan = reply(
        "",
        (
            "set_plan",
            {"steps": [{"id": "s1", "title": "Drive", "tool": "navigation.navigate_to"}]},
        ),
        ("navigation.navigate_to", {"step_id": "s1", "location": "kitchen"}),
    )
    h = make_harness(
        tmp_path,
        FakeLLM([plan, reply("", ("wait_for_events", {"reason": "driving"}))]),
        policy=ToolPolicy.load(tmp_path / "policy.yaml"),
        approvals=broker,
        emitter=emitter,
        trace=trace,
    )
    mission = await h.executor.start("go to the kitchen")
    await async_wait_until(
        lambda: [e for e in emitter.events if isinstance(e, ApprovalRequested)], 5, "asked"
    )

    told = await h.executor.on_user_turn("cancel")

    await h.executor.wait_idle(5)
    assert told is not None
    assert told.startswith("Aborting the mission")
    assert mission.state == "cancelled"
    assert [e.decision for e in emitter.events if isinstance(e, ApprovalResolved)] == ["deny"]
    assert h.tools.called("navigation.navigate_to") == []
