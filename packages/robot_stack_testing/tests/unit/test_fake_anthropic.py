"""The fake Messages API rejects, as the real one does, every request our adapter must never
send; each rule has a request that breaks it (400, the API's error shape)."""

from __future__ import annotations

import copy
from collections.abc import Iterator
from typing import Any

import httpx
import pytest

from robot_stack_testing.fake_anthropic import FakeAnthropicApi, sign
from robot_stack_testing.fake_api_server import serve_in_thread

HEADERS = {"x-api-key": "k", "anthropic-version": "2023-06-01"}
TOOL = {"name": "navigation__navigate_to", "input_schema": {"type": "object"}}


def call_tool(body: dict[str, Any]) -> list[dict[str, Any]]:
    return [{"type": "tool_use", "name": "navigation__navigate_to", "input": {"location": "x"}}]


@pytest.fixture
def api() -> Iterator[tuple[FakeAnthropicApi, httpx.Client]]:
    fake = FakeAnthropicApi(call_tool)
    with serve_in_thread(fake.app()) as url, httpx.Client(base_url=url, timeout=10) as client:
        yield fake, client


def valid() -> dict[str, Any]:
    return {
        "model": "claude-opus-4-8",
        "max_tokens": 1000,
        "thinking": {"type": "adaptive"},
        "tools": [TOOL],
        "messages": [{"role": "user", "content": [{"type": "text", "text": "go"}]}],
    }


def post(
    client: httpx.Client, body: dict[str, Any], headers: dict[str, str] = HEADERS
) -> httpx.Response:
    return client.post("/v1/messages", json=body, headers=headers)


def rejected(client: httpx.Client, body: dict[str, Any], fragment: str) -> None:
    response = post(client, body)
    assert response.status_code == 400, response.text
    error = response.json()
    assert error["type"] == "error"
    assert error["error"]["type"] == "invalid_request_error"
    assert fragment in error["error"]["message"]


def turn_after(client: httpx.Client) -> tuple[dict[str, Any], dict[str, Any]]:
    """A valid first exchange: the assistant turn as answered, and the request that led to it."""
    body = valid()
    answer = post(client, body).json()
    return body, {"role": "assistant", "content": answer["content"]}


def result_for(assistant: dict[str, Any], text: str = "ok") -> dict[str, Any]:
    use = next(b for b in assistant["content"] if b["type"] == "tool_use")
    return {
        "role": "user",
        "content": [{"type": "tool_result", "tool_use_id": use["id"], "content": text}],
    }


def test_a_valid_tool_loop_is_answered_with_signed_thinking_and_usage(
    api: tuple[FakeAnthropicApi, httpx.Client],
) -> None:
    fake, client = api
    body, assistant = turn_after(client)
    assert assistant["content"][0]["type"] == "thinking"
    body["messages"] += [assistant, result_for(assistant)]
    answer = post(client, body)
    assert answer.status_code == 200, answer.text
    usage = answer.json()["usage"]
    assert usage["cache_read_input_tokens"] > 0  # same tools + system as the first call
    assert len(fake.requests) == 2
    assert not fake.rejections


def test_max_tokens_and_model_are_required(api: tuple[FakeAnthropicApi, httpx.Client]) -> None:
    _, client = api
    body = valid()
    del body["max_tokens"]
    rejected(client, body, "max_tokens: Field required")
    body = valid()
    del body["model"]
    rejected(client, body, "model: Field required")


def test_sampling_parameters_and_budget_tokens_are_refused_with_adaptive_thinking(
    api: tuple[FakeAnthropicApi, httpx.Client],
) -> None:
    _, client = api
    rejected(client, {**valid(), "temperature": 0.2}, "temperature")
    body = valid()
    body["thinking"]["budget_tokens"] = 1000
    rejected(client, body, "budget_tokens")


def test_tool_names_with_dots_or_over_64_characters_are_refused(
    api: tuple[FakeAnthropicApi, httpx.Client],
) -> None:
    _, client = api
    rejected(client, {**valid(), "tools": [{**TOOL, "name": "navigation.navigate_to"}]}, "pattern")
    rejected(client, {**valid(), "tools": [{**TOOL, "name": "a" * 65}]}, "pattern")
    rejected(client, {**valid(), "tools": [TOOL, TOOL]}, "unique")


def test_a_tool_needs_an_object_input_schema_nested_definitions_are_fine(
    api: tuple[FakeAnthropicApi, httpx.Client],
) -> None:
    _, client = api
    bare = {k: v for k, v in TOOL.items() if k != "input_schema"}
    rejected(client, {**valid(), "tools": [bare]}, "input_schema: Field required")
    listed = {**TOOL, "input_schema": {"type": "array", "items": {"type": "string"}}}
    rejected(client, {**valid(), "tools": [listed]}, "Input should be 'object'")
    nested = {
        **TOOL,
        "input_schema": {
            "type": "object",
            "$defs": {"MaskRef": {"type": "object", "properties": {"stamp": {"type": "number"}}}},
            "properties": {"mask_ref": {"$ref": "#/$defs/MaskRef"}},
        },
    }
    assert post(client, {**valid(), "tools": [nested]}).status_code == 200


def test_roles_must_start_with_the_user_and_alternate(
    api: tuple[FakeAnthropicApi, httpx.Client],
) -> None:
    _, client = api
    body = valid()
    body["messages"] = [{"role": "assistant", "content": "hi"}, *body["messages"]]
    rejected(client, body, 'first message must use the "user" role')
    body = valid()
    body["messages"] += [{"role": "user", "content": "again"}]
    rejected(client, body, "roles must alternate")
    body = valid()
    body["messages"][0]["role"] = "system"
    rejected(client, body, "Input should be 'user' or 'assistant'")


def test_empty_text_blocks_are_refused(api: tuple[FakeAnthropicApi, httpx.Client]) -> None:
    _, client = api
    body = valid()
    body["messages"][0]["content"].append({"type": "text", "text": "  "})
    rejected(client, body, "text content blocks must be non-empty")
    body = valid()
    body["messages"][0]["content"] = []
    rejected(client, body, "non-empty content")


def test_every_tool_use_needs_its_tool_result_in_the_next_user_turn(
    api: tuple[FakeAnthropicApi, httpx.Client],
) -> None:
    _, client = api
    body, assistant = turn_after(client)
    unanswered = copy.deepcopy(body)
    unanswered["messages"] += [assistant, {"role": "user", "content": "what now?"}]
    rejected(client, unanswered, "`tool_use` ids were found without `tool_result` blocks")
    stray = copy.deepcopy(body)
    bad = result_for(assistant)
    bad["content"].append({**bad["content"][0], "tool_use_id": "toolu_other"})
    stray["messages"] += [assistant, bad]
    rejected(client, stray, "unexpected `tool_use_id`")
    text_first = copy.deepcopy(body)
    answer = result_for(assistant)
    answer["content"].insert(0, {"type": "text", "text": "note"})
    text_first["messages"] += [assistant, answer]
    rejected(client, text_first, "tool_result blocks must come first")


def test_thinking_blocks_must_come_back_unchanged_and_first(
    api: tuple[FakeAnthropicApi, httpx.Client],
) -> None:
    _, client = api
    body, assistant = turn_after(client)
    edited = copy.deepcopy(assistant)
    edited["content"][0]["thinking"] = "something else"
    rejected(
        client,
        {**body, "messages": [*body["messages"], edited, result_for(assistant)]},
        "Invalid `signature`",
    )
    dropped = {"role": "assistant", "content": assistant["content"][1:]}
    rejected(
        client,
        {**body, "messages": [*body["messages"], dropped, result_for(assistant)]},
        "must start with a thinking block",
    )
    assert sign("x") != sign("y")


def test_missing_key_is_401_and_an_outage_answers_with_the_status_set(
    api: tuple[FakeAnthropicApi, httpx.Client],
) -> None:
    fake, client = api
    response = post(client, valid(), {"anthropic-version": "2023-06-01"})
    assert response.status_code == 401
    assert response.json()["error"]["type"] == "authentication_error"
    fake.fail_status = 529
    response = post(client, valid())
    assert response.status_code == 529
    assert response.json()["error"]["type"] == "overloaded_error"


def test_streaming_sends_the_message_as_server_sent_events(
    api: tuple[FakeAnthropicApi, httpx.Client],
) -> None:
    fake, client = api
    fake.responder = lambda body: [{"type": "text", "text": "Hello there."}]
    response = post(client, {**valid(), "stream": True})
    kinds = [
        line[len("event: ") :] for line in response.text.splitlines() if line.startswith("event: ")
    ]
    assert kinds[0] == "message_start"
    assert kinds[-1] == "message_stop"
    assert "signature_delta" in response.text
    assert "text_delta" in response.text
