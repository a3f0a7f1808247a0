"""The fake OpenAI-compatible API rejects what the real one rejects (400, the API's shape)."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import httpx
import pytest

from robot_stack_testing.fake_api_server import serve_in_thread
from robot_stack_testing.fake_openai import FakeOpenAIApi

AUTH = {"Authorization": "Bearer k"}
FUNCTION = {"type": "function", "function": {"name": "navigation__navigate_to", "parameters": {}}}


def answer(body: dict[str, Any]) -> dict[str, Any]:
    return {
        "content": None,
        "tool_calls": [{"name": "navigation__navigate_to", "arguments": {"location": "x"}}],
    }


@pytest.fixture
def api() -> Iterator[tuple[FakeOpenAIApi, httpx.Client]]:
    fake = FakeOpenAIApi(answer)
    with serve_in_thread(fake.app()) as url, httpx.Client(base_url=url, timeout=10) as client:
        yield fake, client


def valid() -> dict[str, Any]:
    return {"model": "m", "messages": [{"role": "user", "content": "go"}], "tools": [FUNCTION]}


def rejected(client: httpx.Client, body: dict[str, Any], fragment: str) -> None:
    response = client.post("/v1/chat/completions", json=body, headers=AUTH)
    assert response.status_code == 400, response.text
    error = response.json()["error"]
    assert error["type"] == "invalid_request_error"
    assert fragment in error["message"]


def assistant_call(call_id: str = "call_1") -> dict[str, Any]:
    call = {
        "id": call_id,
        "type": "function",
        "function": {"name": "navigation__navigate_to", "arguments": "{}"},
    }
    return {"role": "assistant", "content": None, "tool_calls": [call]}


def test_a_valid_tool_round_trip_is_answered(api: tuple[FakeOpenAIApi, httpx.Client]) -> None:
    fake, client = api
    body = valid()
    body["messages"] += [
        assistant_call(),
        {"role": "tool", "tool_call_id": "call_1", "content": "ok"},
    ]
    response = client.post("/v1/chat/completions", json=body, headers=AUTH)
    assert response.status_code == 200, response.text
    choice = response.json()["choices"][0]
    assert choice["finish_reason"] == "tool_calls"
    assert choice["message"]["tool_calls"][0]["function"]["name"] == "navigation__navigate_to"
    assert not fake.rejections


def test_function_names_must_match_the_pattern(api: tuple[FakeOpenAIApi, httpx.Client]) -> None:
    _, client = api
    dotted = {"type": "function", "function": {"name": "navigation.navigate_to"}}
    rejected(client, {**valid(), "tools": [dotted]}, "does not match pattern")
    body = valid()
    call = assistant_call()
    call["tool_calls"][0]["function"]["name"] = "a.b"
    body["messages"] += [call, {"role": "tool", "tool_call_id": "call_1", "content": "ok"}]
    rejected(client, body, "does not match pattern")


def test_every_tool_call_id_needs_a_tool_message_and_no_stray_tool_messages(
    api: tuple[FakeOpenAIApi, httpx.Client],
) -> None:
    _, client = api
    body = valid()
    body["messages"] += [assistant_call(), {"role": "user", "content": "and?"}]
    rejected(client, body, "did not have response messages: call_1")
    body = valid()
    body["messages"] += [{"role": "tool", "tool_call_id": "call_9", "content": "ok"}]
    rejected(client, body, "must be a response to a preceeding message with 'tool_calls'")


def test_model_messages_roles_and_content_are_checked(
    api: tuple[FakeOpenAIApi, httpx.Client],
) -> None:
    _, client = api
    rejected(client, {"messages": valid()["messages"]}, "you must provide a model parameter")
    rejected(client, {"model": "m", "messages": []}, "'messages' is a required property")
    rejected(
        client,
        {"model": "m", "messages": [{"role": "robot", "content": "x"}]},
        "Invalid value: 'robot'",
    )
    rejected(client, {"model": "m", "messages": [{"role": "user", "content": None}]}, "got null")


def test_streaming_sends_chunks_then_done(api: tuple[FakeOpenAIApi, httpx.Client]) -> None:
    fake, client = api
    fake.responder = lambda body: {"content": "Hello there."}
    response = client.post("/v1/chat/completions", json={**valid(), "stream": True}, headers=AUTH)
    assert response.text.rstrip().endswith("data: [DONE]")
    assert '"finish_reason": "stop"' in response.text


def test_a_missing_key_is_401(api: tuple[FakeOpenAIApi, httpx.Client]) -> None:
    _, client = api
    response = client.post("/v1/chat/completions", json=valid())
    assert response.status_code == 401


def test_transcription_needs_a_multipart_file_with_a_known_format_and_a_model(
    api: tuple[FakeOpenAIApi, httpx.Client],
) -> None:
    fake, client = api
    url = "/v1/audio/transcriptions"
    ok = client.post(
        url,
        files={"file": ("u.webm", b"abc", "audio/webm")},
        data={"model": "whisper-1"},
        headers=AUTH,
    )
    assert ok.json() == {"text": "hello robot"}
    no_model = client.post(url, files={"file": ("u.webm", b"abc", "audio/webm")}, headers=AUTH)
    assert no_model.status_code == 400
    assert "model" in no_model.json()["error"]["message"]
    no_file = client.post(url, files={"model": (None, b"whisper-1")}, headers=AUTH)
    assert no_file.status_code == 400
    assert "'file'" in no_file.json()["error"]["message"]
    bad = client.post(
        url, files={"file": ("u.txt", b"abc", "text/plain")}, data={"model": "w"}, headers=AUTH
    )
    assert bad.status_code == 400
    assert "Invalid file format" in bad.json()["error"]["message"]
    as_json = client.post(url, json={"model": "w"}, headers=AUTH)
    assert as_json.status_code == 400
    assert fake.transcriptions == [{"model": "whisper-1", "file": "u.webm"}]
