"""One mission at a time under concurrent requests (issue 23 items 1 and 2): parallel
``POST /api/chat`` start exactly one mission, nobody's drive is stopped by another request,
and every request, also those that land in the running mission, gets an answer."""

from __future__ import annotations

import asyncio
from collections.abc import AsyncIterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import httpx
import pytest

from robot_stack_testing import async_wait_until
from robot_stack_testing.brain.harness import nav_servers
from robot_stack_testing.brain.life import brain_life
from robot_stack_testing.brain.office_world import OfficeWorld
from robot_voice_chat.api.app import create_app
from robot_voice_chat.api.container import Container
from robot_voice_chat.services.emitter.base import FakeEventEmitter
from robot_voice_chat.services.llm.rules.chat import RulesChat
from robot_voice_chat.services.llm.rules.planner import RulesPlanner
from robot_voice_chat.services.speech.fake import FakeSpeechOutput
from robot_voice_chat.services.tools.fake import FakeToolBackend
from robot_voice_chat.socket_events import ChatMessage, MissionEventLine, MissionStarted

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

    def missions_started(self) -> list[MissionStarted]:
        return [e for e in self.emitter.events if isinstance(e, MissionStarted)]


@pytest.fixture
async def brain(tmp_path: Path) -> AsyncIterator[Brain]:
    tools = FakeToolBackend(nav_servers())
    world = OfficeWorld(tools, drive_s=30.0)  # drives outlast the bursts below
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


@pytest.mark.parametrize("n", [2, 20])
async def test_concurrent_starts_make_exactly_one_mission_and_answer_everyone(
    brain: Brain, n: int
) -> None:
    texts = [f"go to the {PLACES[i % len(PLACES)]}" for i in range(n)]
    answers = await asyncio.gather(*(brain.chat(t) for t in texts))

    started = [a for a in answers if a["route"] == "mission_started"]
    assert len(started) == 1, answers
    assert len(brain.missions_started()) == 1
    assert len(brain.container.executor.store.recent(100)) == 1
    for answer in answers:
        assert answer["reply"].strip(), answer  # nobody is left without an answer
        if answer["route"] != "mission_started":
            assert "busy" in answer["reply"], answer
            assert "stop" in answer["reply"], answer

    # the one mission drives, and no other request stopped or cancelled its drive
    await async_wait_until(
        lambda: brain.container.executor.registry.live(), 10, "the mission's drive registered"
    )
    assert len(brain.world.tools.called("navigation.navigate_to")) == 1
    assert brain.world.tools.called("navigation.stop_navigation") == []
    assert brain.world.tools.called("navigation.cancel_task") == []
    mission = brain.container.executor.active
    assert mission is not None
    assert mission.state == "running"


async def test_every_turn_during_a_mission_is_answered_and_the_planner_says_so(
    brain: Brain,
) -> None:
    first = await brain.chat("go to the kitchen")
    assert first["route"] == "mission_started"
    executor = brain.container.executor
    await async_wait_until(lambda: executor.registry.live(), 10, "driving")

    turns = [f"what are you doing {i}?" for i in range(20)]
    answers = await asyncio.gather(*(brain.chat(t) for t in turns))

    shown = {
        e.turn_id: e.text
        for e in brain.emitter.events
        if isinstance(e, ChatMessage) and e.role == "assistant"
    }
    for answer in answers:
        assert shown[answer["turn_id"]] == answer["reply"]  # the UI shows every answer too
        assert answer["route"] == "mission"
        assert "kitchen" in answer["reply"], answer
        assert "stop" in answer["reply"], answer

    # the rules planner answers mid-mission turns briefly with say (spec 002 §5.1)
    def said() -> list[str]:
        return [
            e.text
            for e in brain.emitter.events
            if isinstance(e, MissionEventLine) and e.kind == "say"
        ]

    await async_wait_until(said, 10, "the planner's answer")
    assert "I'm busy driving to the kitchen" in said()[0]
    assert "say stop to halt me" in said()[0]
    assert executor.active is not None
    assert executor.active.state == "running"
    assert brain.world.tools.called("navigation.stop_navigation") == []


async def test_twenty_turns_during_one_drive_are_each_answered_but_said_aloud_once(
    brain: Brain,
) -> None:
    """Issue 31: the robot said "I heard …, but I'm busy" once per message (21 for 20)."""
    assert (await brain.chat("go to the kitchen"))["route"] == "mission_started"
    executor = brain.container.executor
    await async_wait_until(lambda: executor.registry.live(), 10, "driving")
    run = executor.run
    assert run is not None
    for i in range(20):  # one after the other: each wakes the planner on its own
        seen = len(run.messages)  # a step woken by the person's turn is not counted in llm_steps
        answer = await brain.chat(f"are you there {i}?")
        assert answer["route"] == "mission", answer
        assert "stop" in answer["reply"], answer
        await async_wait_until(
            lambda m=seen: len(run.messages) > m and not run.inbox and run.suspended,
            10,
            "the planner heard it",
        )
    busy = [s for s in brain.speech.spoken if "busy" in s]
    assert len(busy) == 1, busy
    assert executor.active is not None
    assert executor.active.state == "running"


async def test_with_navigation_down_a_rest_caller_is_told_the_refusal_not_an_ok(
    brain: Brain,
) -> None:
    """Issue 31: "OK, I'll go to the kitchen." answered, the refusal 0.05 s later."""
    brain.world.tools.states["navigation"] = "disconnected"
    answer = await brain.chat("go to the kitchen")
    assert answer["route"] != "mission_started", answer
    assert "OK" not in answer["reply"], answer
    assert "navigation" in answer["reply"], answer
    assert "not connected" in answer["reply"], answer
    assert brain.missions_started() == []
    shown = [e.text for e in brain.emitter.events if isinstance(e, ChatMessage)]
    assert not any(text.startswith("OK, I'll") for text in shown), shown
