"""The model stand-ins behind the strict fake APIs translate the wire both ways."""

from __future__ import annotations

from collections.abc import Generator

import pytest

from robot_stack_testing.brain.fake_wire import (
    anthropic_responder,
    from_openai_request,
    openai_responder,
    run_sync,
)
from robot_voice_chat.services.llm.rules.chat import RulesChat
from robot_voice_chat.services.llm.rules.planner import RulesPlanner


def test_the_rules_chat_answers_an_openai_request_with_wire_names() -> None:
    respond = openai_responder(RulesChat())
    body = {
        "model": "m",
        "messages": [
            {"role": "system", "content": "be brief"},
            {"role": "user", "content": "go to the kitchen"},
        ],
        "tools": [
            {"type": "function", "function": {"name": "start_mission"}},
            {"type": "function", "function": {"name": "navigation__get_pose"}},
        ],
    }
    answer = respond(body)
    assert answer["content"] is None
    assert answer["tool_calls"][0]["name"] == "start_mission"
    assert answer["tool_calls"][0]["arguments"]["ack"] == "OK, I'll go to the kitchen."


def test_openai_tool_messages_become_one_user_turn_of_results() -> None:
    call = {"id": "c1", "type": "function", "function": {"name": "a__b", "arguments": "{}"}}
    messages, tools = from_openai_request(
        {
            "messages": [
                {"role": "user", "content": "x"},
                {"role": "assistant", "content": None, "tool_calls": [call, {**call, "id": "c2"}]},
                {"role": "tool", "tool_call_id": "c1", "content": "one"},
                {"role": "tool", "tool_call_id": "c2", "content": "two"},
            ],
            "tools": [{"type": "function", "function": {"name": "a__b"}}],
        }
    )
    assert messages[1].tool_calls[0].name == "a.b"
    assert [r.content for r in messages[2].tool_results] == ["one", "two"]
    assert tools[0].name == "a.b"


def test_the_rules_planner_answers_an_anthropic_request() -> None:
    respond = anthropic_responder(RulesPlanner())
    body = {
        "system": [{"type": "text", "text": "plan"}],
        "messages": [{"role": "user", "content": [{"type": "text", "text": "go to the lab"}]}],
        "tools": [{"name": "navigation__navigate_to"}, {"name": "navigation__list_locations"}],
    }
    blocks = respond(body)  # the live places first: the request is read against them
    assert [b["name"] for b in blocks] == ["navigation__list_locations"]


class Suspends:
    def __await__(self) -> Generator[None, None, None]:
        yield


def test_run_sync_refuses_a_coroutine_that_awaits() -> None:
    async def suspends() -> None:
        await Suspends()

    with pytest.raises(RuntimeError, match="must not await"):
        run_sync(suspends())
