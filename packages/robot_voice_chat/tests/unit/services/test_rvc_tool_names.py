"""Tool names on the wire: server.tool ↔ server__tool, one bijection shared by the adapters."""

from __future__ import annotations

import pytest

from robot_voice_chat.services.llm.anthropic import AnthropicLLM, from_anthropic
from robot_voice_chat.services.llm.base import LLMError, Message, ToolCall, ToolDefinition
from robot_voice_chat.services.llm.openai_compat import OpenAICompatLLM
from robot_voice_chat.services.llm.tool_names import (
    WIRE_PATTERN,
    ToolNameError,
    ToolNames,
    encode,
)


def test_dotted_names_travel_with_a_double_underscore_and_come_back() -> None:
    names = ToolNames(["navigation.navigate_to", "set_plan"])
    assert names.wire("navigation.navigate_to") == "navigation__navigate_to"
    assert names.wire("set_plan") == "set_plan"
    assert names.app("navigation__navigate_to") == "navigation.navigate_to"
    assert names.app("set_plan") == "set_plan"


def test_names_the_providers_refuse_are_made_valid_and_stay_distinct() -> None:
    long_a = "skill_control." + "a" * 70
    long_b = "skill_control." + "a" * 69 + "b"
    odd = "my server.look/around"
    names = ToolNames([long_a, long_b, odd])
    wires = {names.wire(n) for n in (long_a, long_b, odd)}
    assert len(wires) == 3
    assert all(WIRE_PATTERN.match(w) for w in wires)
    assert all(len(w) <= 64 for w in wires)
    assert {names.app(w) for w in wires} == {long_a, long_b, odd}


def test_two_tools_with_the_same_wire_name_are_a_collision() -> None:
    with pytest.raises(ToolNameError, match="navigation__navigate_to"):
        ToolNames(["navigation.navigate_to", "navigation__navigate_to"])


def test_an_unknown_name_from_the_model_stays_as_sent_so_the_backend_rejects_it() -> None:
    names = ToolNames(["navigation.navigate_to"])
    assert not names.knows("navigation__fly_to")
    assert names.app("navigation__fly_to") == "navigation__fly_to"
    # in the history it goes back exactly as the model sent it
    assert names.wire("navigation__fly_to") == "navigation__fly_to"
    assert encode("a.b") == "a__b"


def test_both_adapters_send_wire_names_and_map_answers_back() -> None:
    tools = [ToolDefinition(name="navigation.navigate_to")]
    history = [
        Message(role="user", content="go"),
        Message(
            role="assistant",
            tool_calls=[ToolCall(id="t1", name="navigation.navigate_to", arguments={})],
        ),
    ]
    anthropic = AnthropicLLM(api_key="k", base_url="http://127.0.0.1:9")
    sent = anthropic.request(history, tools)
    assert sent["tools"][0]["name"] == "navigation__navigate_to"
    assert sent["messages"][1]["content"][0]["name"] == "navigation__navigate_to"
    openai = OpenAICompatLLM(base_url="http://127.0.0.1:9/v1", api_key="k", model="m")
    sent = openai.request(history, tools)
    assert sent["tools"][0]["function"]["name"] == "navigation__navigate_to"
    assert sent["messages"][1]["tool_calls"][0]["function"]["name"] == "navigation__navigate_to"


def test_a_collision_is_an_llm_error_before_any_request() -> None:
    tools = [ToolDefinition(name="a.b"), ToolDefinition(name="a__b")]
    with pytest.raises(LLMError, match="tool names"):
        AnthropicLLM(api_key="k", base_url="http://127.0.0.1:9").request([], tools)


def test_anthropic_answers_map_back_to_dotted_names() -> None:
    class Block:
        def __init__(self, **kw: object) -> None:
            self.__dict__.update(kw)

    message = Block(
        content=[Block(type="tool_use", id="t", name="navigation__navigate_to", input={})],
        stop_reason="tool_use",
        usage=Block(input_tokens=1, output_tokens=1),
    )
    names = ToolNames(["navigation.navigate_to"])
    response = from_anthropic(message, names)
    assert response.tool_calls[0].name == "navigation.navigate_to"
    # provider blocks keep the wire name: they go back to the API verbatim
    assert response.provider_blocks == [
        {"type": "tool_use", "id": "t", "name": "navigation__navigate_to", "input": {}}
    ]
