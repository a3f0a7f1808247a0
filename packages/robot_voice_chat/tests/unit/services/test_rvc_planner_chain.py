"""Degraded mode: the cloud planner fails → the mission goes on with the rules planner, the
person is told once, readyz-visible ``degraded``; the next mission tries the cloud again."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from robot_stack_testing import async_wait_until
from robot_stack_testing.brain.fake_wire import anthropic_responder
from robot_stack_testing.brain.office import office
from robot_stack_testing.fake_anthropic import FakeAnthropicApi
from robot_stack_testing.fake_api_server import serve_in_thread
from robot_voice_chat.services.llm.anthropic import AnthropicLLM
from robot_voice_chat.services.llm.base import LLMError, Message, ToolDefinition
from robot_voice_chat.services.llm.chain import NOTICE, PlannerChain
from robot_voice_chat.services.llm.fake import FakeLLM, reply
from robot_voice_chat.services.llm.rules.planner import RulesPlanner

SAY = [ToolDefinition(name="say")]


def conversation(text: str) -> list[Message]:
    return [Message(role="system", content="s"), Message(role="user", content=text)]


async def test_a_failing_provider_hands_the_conversation_to_the_next_and_tells_once() -> None:
    cloud = FakeLLM([LLMError("anthropic: APIConnectionError"), reply("cloud again")])
    backup = FakeLLM([reply("", ("wait_for_events", {"reason": "x"})), reply("still backup")])
    chain = PlannerChain([cloud, backup])
    assert chain.name == "chain[fake,fake]"
    first = await chain.chat(conversation("go"), SAY)
    assert [c.name for c in first.tool_calls] == ["say", "wait_for_events"]
    assert first.tool_calls[0].arguments == {"text": NOTICE}
    assert chain.degraded
    longer = [*conversation("go"), first.as_message(), Message(role="user", content="[x]")]
    second = await chain.chat(longer, SAY)
    assert second.text == "still backup"  # same mission: stays on the backup, no second notice
    assert len(cloud.requests) == 1
    again = await chain.chat(conversation("next mission"), SAY)
    assert again.text == "cloud again"
    assert not chain.degraded


async def test_the_last_provider_failing_is_the_error() -> None:
    chain = PlannerChain([FakeLLM([LLMError("a")]), FakeLLM([LLMError("b")])])
    with pytest.raises(LLMError, match="b"):
        await chain.chat(conversation("go"), SAY)
    with pytest.raises(ValueError, match="at least one"):
        PlannerChain([])


@pytest.fixture
def cloud() -> Iterator[tuple[FakeAnthropicApi, str]]:
    fake = FakeAnthropicApi(anthropic_responder(RulesPlanner()))
    with serve_in_thread(fake.app()) as url:
        yield fake, url


async def test_the_cloud_going_down_mid_mission_finishes_on_rules(
    tmp_path: Path, cloud: tuple[FakeAnthropicApi, str]
) -> None:
    fake, url = cloud
    anthropic = AnthropicLLM(api_key="k", base_url=url, max_retries=0, request_timeout_s=10)
    chain = PlannerChain([anthropic, RulesPlanner()])
    assert chain.understanding_label == "anthropic, fallback rules + embedded matcher"
    o = office(tmp_path, drive_s=0.3, arm=True)
    o.executor.planner = chain
    mission = await o.executor.start("Please fetch the package from the mailroom.")
    await async_wait_until(lambda: o.tools.called("navigation.navigate_to"), 10, "driving")
    fake.fail_status = 500  # the cloud goes down while the robot drives
    await o.executor.wait_idle(20)

    assert mission.state == "succeeded", mission.summary
    assert "yellow package" in mission.summary
    assert chain.degraded
    assert chain.understanding_label == "rules + embedded matcher (fallback: anthropic failed)"
    assert o.speech.spoken.count(NOTICE) == 1
    assert not fake.rejections  # every request that reached the API was valid
    assert len(fake.requests) >= 2  # the cloud planned until it went down

    fake.fail_status = None
    before = len(fake.requests)
    mission = await o.run("go to the kitchen")
    assert mission.state == "succeeded", mission.summary
    assert len(fake.requests) > before  # the next mission tried the cloud first
    assert not chain.degraded
    assert not fake.rejections
    await chain.aclose()
