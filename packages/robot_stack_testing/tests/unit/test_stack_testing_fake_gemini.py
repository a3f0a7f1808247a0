"""The local fake Gemini API refuses what the real generateContent refuses (one test per rule),
so a grounder request that passes it has the shape the real service accepts."""

from __future__ import annotations

import base64
from collections.abc import Iterator
from typing import Any

import httpx
import pytest

from robot_stack_testing.perception.fake_gemini import FakeGemini, serve_fake_gemini

MODEL_PATH = "/v1beta/models/gemini-robotics-er-2-preview:generateContent"
JPEG_B64 = base64.b64encode(b"\xff\xd8\xff\xe0 not really a jpeg").decode()


@pytest.fixture
def fake() -> Iterator[tuple[FakeGemini, httpx.Client]]:
    app = FakeGemini(api_key="k")
    with serve_fake_gemini(app) as url, httpx.Client(base_url=url, timeout=10.0) as client:
        yield app, client


def valid() -> dict[str, Any]:
    return {
        "contents": [
            {
                "role": "user",
                "parts": [
                    {"inlineData": {"mimeType": "image/jpeg", "data": JPEG_B64}},
                    {"text": "point at the mug"},
                ],
            }
        ],
        "generationConfig": {
            "temperature": 0.5,
            "responseMimeType": "application/json",
            "thinkingConfig": {"thinkingBudget": 1024},
        },
    }


def post(client: httpx.Client, body: Any, key: str | None = "k", path: str = MODEL_PATH) -> Any:
    headers = {"x-goog-api-key": key} if key else {}
    return client.post(path, json=body, headers=headers)


def rejected(client: httpx.Client, body: Any, **kwargs: Any) -> str:
    response = post(client, body, **kwargs)
    assert response.status_code in (400, 403, 404), response.text
    error = response.json()["error"]
    assert error["code"] == response.status_code
    return str(error["message"])


def test_a_well_formed_request_in_camel_or_snake_case_is_answered(fake: Any) -> None:
    app, client = fake
    assert post(client, valid()).status_code == 200
    snake = valid()
    snake["generation_config"] = snake.pop("generationConfig")
    del snake["generation_config"]["thinkingConfig"]
    snake["generation_config"]["thinking_config"] = {"thinking_budget": 0}
    snake["contents"][0]["parts"][0] = {"inline_data": {"mime_type": "image/png", "data": "AA"}}
    assert post(client, snake).status_code == 200
    assert len(app.requests) == 2
    assert app.rejected == []
    both = valid()
    both["generationConfig"]["thinking_config"] = {"thinking_budget": 0}
    assert "Duplicate field" in rejected(client, both)


def test_a_request_without_an_api_key_is_refused_and_a_wrong_key_is_api_key_invalid(
    fake: Any,
) -> None:
    app, client = fake
    assert "unregistered callers" in rejected(client, valid(), key=None)
    response = post(client, valid(), key="wrong")
    assert response.status_code == 400
    assert response.json()["error"]["details"][0]["reason"] == "API_KEY_INVALID"
    assert app.requests == []


def test_an_unknown_path_or_method_is_not_found(fake: Any) -> None:
    _, client = fake
    assert "not found" in rejected(client, valid(), path="/v1beta/models/x:predict")
    assert client.get(MODEL_PATH, headers={"x-goog-api-key": "k"}).status_code == 404


def test_unknown_top_level_fields_are_refused(fake: Any) -> None:
    _, client = fake
    assert 'Unknown name "prompt"' in rejected(client, {**valid(), "prompt": "hi"})


def test_contents_must_be_a_non_empty_list(fake: Any) -> None:
    _, client = fake
    assert "contents is not specified" in rejected(client, {**valid(), "contents": []})
    body = valid()
    del body["contents"]
    assert "contents is not specified" in rejected(client, body)


def test_a_role_other_than_user_or_model_is_refused(fake: Any) -> None:
    _, client = fake
    body = valid()
    body["contents"][0]["role"] = "assistant"
    assert "valid role: user, model" in rejected(client, body)


def test_parts_must_not_be_empty(fake: Any) -> None:
    _, client = fake
    body = valid()
    body["contents"][0]["parts"] = []
    assert "parts must not be empty" in rejected(client, body)


def test_a_part_needs_exactly_one_data_field(fake: Any) -> None:
    _, client = fake
    body = valid()
    body["contents"][0]["parts"] = [{"thought": True}]
    assert "oneof field 'data'" in rejected(client, body)
    body["contents"][0]["parts"] = [{"text": "a", "inlineData": {"mimeType": "image/png"}}]
    assert "oneof field 'data'" in rejected(client, body)
    body["contents"][0]["parts"] = [{"text": "a", "colour": "red"}]
    assert 'Unknown name "colour"' in rejected(client, body)


@pytest.mark.parametrize("mime", ["image/bmp", "application/octet-stream", "image/jpg"])
def test_inline_data_with_an_unsupported_mime_type_is_refused(fake: Any, mime: str) -> None:
    _, client = fake
    body = valid()
    body["contents"][0]["parts"][0]["inlineData"]["mimeType"] = mime
    assert f"Unsupported MIME type: {mime}" in rejected(client, body)


def test_inline_data_needs_a_mime_type_and_base64_data(fake: Any) -> None:
    _, client = fake
    body = valid()
    del body["contents"][0]["parts"][0]["inlineData"]["mimeType"]
    assert "mime_type: required" in rejected(client, body)
    body = valid()
    body["contents"][0]["parts"][0]["inlineData"]["data"] = "not base64 at all!"
    assert "Base64 decoding failed" in rejected(client, body)


def test_unknown_generation_config_fields_are_refused(fake: Any) -> None:
    _, client = fake
    body = valid()
    body["generationConfig"]["max_tokens"] = 100
    assert 'Unknown name "max_tokens"' in rejected(client, body)


@pytest.mark.parametrize(
    ("key", "value", "message"),
    [
        ("temperature", 3.0, "out of range"),
        ("temperature", "hot", "TYPE_FLOAT"),
        ("topP", 1.5, "out of range"),
        ("candidateCount", 0, "out of range"),
        ("maxOutputTokens", 1.5, "TYPE_INT32"),
        ("responseMimeType", "application/xml", "allowed mimetypes"),
    ],
)
def test_generation_config_values_out_of_range_are_refused(
    fake: Any, key: str, value: Any, message: str
) -> None:
    _, client = fake
    body = valid()
    body["generationConfig"][key] = value
    assert message in rejected(client, body)


def test_thinking_config_accepts_only_its_fields_and_valid_values(fake: Any) -> None:
    _, client = fake

    def with_thinking(thinking: dict[str, Any]) -> dict[str, Any]:
        body = valid()
        body["generationConfig"]["thinkingConfig"] = thinking
        return body

    assert 'Unknown name "budget"' in rejected(client, with_thinking({"budget": 10}))
    assert "out of range" in rejected(client, with_thinking({"thinkingBudget": -2}))
    assert "TYPE_INT32" in rejected(client, with_thinking({"thinkingBudget": "high"}))
    assert "thinking_level" in rejected(client, with_thinking({"thinkingLevel": "EXTREME"}))
    both = with_thinking({"thinkingBudget": 128, "thinkingLevel": "LOW"})
    assert "only one of thinking budget and thinking level" in rejected(client, both)
    assert "TYPE_BOOL" in rejected(client, with_thinking({"includeThoughts": "yes"}))
    assert post(client, with_thinking({"thinkingLevel": "LOW"})).status_code == 200
    assert post(client, with_thinking({"thinkingBudget": -1})).status_code == 200


def test_a_body_that_is_not_a_json_object_is_refused(fake: Any) -> None:
    _, client = fake
    headers = {"x-goog-api-key": "k", "content-type": "application/json"}
    assert client.post(MODEL_PATH, content=b"{oops", headers=headers).status_code == 400
    assert "expected an object" in rejected(client, ["contents"])


def test_scripted_replies_are_served_in_order_and_the_last_repeats(fake: Any) -> None:
    app, client = fake
    app.replies = [(503, {"error": {"code": 503, "message": "busy"}}), (200, "hello")]
    assert post(client, valid()).status_code == 503
    for _ in range(2):
        reply = post(client, valid()).json()
        assert reply["candidates"][0]["content"]["parts"][0]["text"] == "hello"


def test_a_flaky_fake_answers_every_nth_request_503(fake: Any) -> None:
    app, client = fake
    app.fail_every = 2
    assert [post(client, valid()).status_code for _ in range(4)] == [200, 503, 200, 503]
