"""AnthropicLLM through the real ``anthropic`` SDK against the strict local Messages API
(robot_stack_testing.fake_anthropic): every request the adapter sends must pass the checks
the real API makes (§7)."""

from __future__ import annotations

from collections.abc import AsyncIterator, Iterator
from typing import Any

import pytest

from robot_stack_testing.fake_anthropic import FakeAnthropicApi
from robot_stack_testing.fake_api_server import serve_in_thread
from robot_voice_chat.services.llm.anthropic import AnthropicLLM
from robot_voice_chat.services.llm.base import (
    LLMError,
    Message,
    ToolCall,
    ToolDefinition,
    ToolResult,
)

Blocks = list[dict[str, Any]]


class Script:
    """Answers in order (content blocks without ids)."""

    def __init__(self) -> None:
        self.answers: list[Blocks] = []

    def __call__(self, body: dict[str, Any]) -> Blocks:
        return self.answers.pop(0) if self.answers else [{"type": "text", "text": "ok"}]


@pytest.fixture
def api() -> Iterator[tuple[FakeAnthropicApi, Script, str]]:
    script = Script()
    fake = FakeAnthropicApi(script)
    with serve_in_thread(fake.app()) as url:
        yield fake, script, url


@pytest.fixture
async def clients() -> AsyncIterator[list[AnthropicLLM]]:
    made: list[AnthropicLLM] = []
    yield made
    for client in made:
        await client.aclose()


def llm(url: str, made: list[AnthropicLLM], **kw: Any) -> AnthropicLLM:
    client = AnthropicLLM(api_key="test", base_url=url, max_retries=kw.pop("max_retries", 0), **kw)
    made.append(client)
    return client


CONVERSATION = [
    Message(role="system", content="You are the mission planner."),
    Message(role="user", content="drive to the mailroom"),
    Message(
        role="assistant",
        content="",
        tool_calls=[
            ToolCall(id="tu_1", name="navigation.navigate_to", arguments={"location": "mailroom"})
        ],
    ),
    Message(
        role="user", tool_results=[ToolResult(tool_call_id="tu_1", content='{"task_id":"nav-1"}')]
    ),
    Message(role="user", content="[task nav-1] done"),
]
TOOLS = [
    ToolDefinition(
        name="set_plan", description="plan", parameters={"type": "object", "properties": {}}
    ),
    ToolDefinition(name="navigation.navigate_to", description="drive"),
]


async def test_request_shape_and_tool_translation_both_ways(
    api: tuple[FakeAnthropicApi, Script, str], clients: list[AnthropicLLM]
) -> None:
    fake, script, url = api
    script.answers.append(
        [
            {"type": "text", "text": "Planning."},
            {"type": "tool_use", "name": "navigation__navigate_to", "input": {"location": "x"}},
        ]
    )
    prices = {"input": 5.0, "output": 25.0, "cache_read": 0.5, "cache_write": 6.25}
    response = await llm(url, clients, prices=prices).chat(CONVERSATION, TOOLS)

    assert not fake.rejections
    sent = fake.requests[0]
    assert sent["model"] == "claude-opus-4-8"
    assert sent["max_tokens"] == 16000
    assert sent["thinking"] == {"type": "adaptive"}
    assert sent["output_config"] == {"effort": "high"}
    assert not {"temperature", "top_p", "top_k"} & set(sent)
    assert sent["system"] == [
        {
            "type": "text",
            "text": "You are the mission planner.",
            "cache_control": {"type": "ephemeral"},
        }
    ]
    assert [t["name"] for t in sent["tools"]] == ["set_plan", "navigation__navigate_to"]
    assert [m["role"] for m in sent["messages"]] == ["user", "assistant", "user"]
    assert sent["messages"][1]["content"][0]["name"] == "navigation__navigate_to"
    assert sent["messages"][2]["content"] == [
        {
            "type": "tool_result",
            "tool_use_id": "tu_1",
            "content": '{"task_id":"nav-1"}',
            "is_error": False,
        },
        {"type": "text", "text": "[task nav-1] done"},
    ]

    assert response.has_tool_calls
    [call] = response.tool_calls
    assert call.name == "navigation.navigate_to"  # back to the app's dotted name
    assert call.arguments == {"location": "x"}
    assert response.text == "Planning."
    assert response.usage.input_tokens > 0
    assert response.usage.cache_write_tokens > 0
    usage = response.usage
    expected = (
        usage.input_tokens * 5 + usage.output_tokens * 25 + usage.cache_write_tokens * 6.25
    ) / 1e6
    assert usage.cost_usd == round(expected, 8)
    # the signed thinking block goes back verbatim on the next step: the strict API checks it
    answered = Message(role="user", tool_results=[ToolResult(tool_call_id=call.id, content="ok")])
    again = await llm(url, clients).chat([*CONVERSATION, response.as_message(), answered], TOOLS)
    assert not fake.rejections
    assert fake.requests[1]["messages"][3]["content"][0]["type"] == "thinking"
    assert again.usage.cache_read_tokens > 0


async def test_a_history_the_api_rejects_is_an_llm_error_not_a_hang(
    api: tuple[FakeAnthropicApi, Script, str], clients: list[AnthropicLLM]
) -> None:
    fake, _, url = api
    broken = [*CONVERSATION[:3], Message(role="user", content="no tool result")]
    with pytest.raises(LLMError, match="tool_result"):
        await llm(url, clients).chat(broken, TOOLS)
    assert fake.rejections


async def test_streaming_yields_text_deltas_then_the_final_response(
    api: tuple[FakeAnthropicApi, Script, str], clients: list[AnthropicLLM]
) -> None:
    fake, script, url = api
    script.answers.append([{"type": "text", "text": "Hello there."}])
    events = [e async for e in llm(url, clients).chat_stream(CONVERSATION[:2])]
    assert [e.delta for e in events[:-1]] == ["Hello ", "there."]
    final = events[-1].response
    assert final is not None
    assert final.text == "Hello there."
    assert fake.requests[0]["stream"] is True


async def test_overloaded_and_server_errors_are_retried(
    api: tuple[FakeAnthropicApi, Script, str], clients: list[AnthropicLLM]
) -> None:
    fake, script, url = api
    fake.fail_next += [529, 500]
    script.answers.append([{"type": "text", "text": "finally"}])
    response = await llm(url, clients, max_retries=2).chat(CONVERSATION[:2])
    assert response.text == "finally"
    assert not fake.fail_next


async def test_exhausted_retries_and_timeouts_become_llm_errors(
    api: tuple[FakeAnthropicApi, Script, str], clients: list[AnthropicLLM]
) -> None:
    fake, _, url = api
    fake.fail_next.append(529)
    with pytest.raises(LLMError, match="anthropic"):
        await llm(url, clients).chat(CONVERSATION[:2])
    fake.delay_s = 1.5
    with pytest.raises(LLMError, match="Timeout"):
        await llm(url, clients, request_timeout_s=0.3).chat(CONVERSATION[:2])


def test_an_empty_key_is_refused_when_the_adapter_is_selected() -> None:
    with pytest.raises(ValueError, match="ANTHROPIC_API_KEY is empty"):
        AnthropicLLM(api_key="")
