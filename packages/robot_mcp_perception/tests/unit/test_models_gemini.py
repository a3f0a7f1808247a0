"""GeminiERGrounder with the real google-genai SDK against a local fake Gemini HTTP server."""

from __future__ import annotations

import base64
import json
from collections.abc import AsyncIterator, Iterator
from typing import Any

import cv2
import numpy as np
import pytest
from pydantic import SecretStr

from robot_mcp_perception.models.base import ModelError, ModelUnavailableError, SemanticRequest
from robot_mcp_perception.models.gemini_er import (
    DEFAULT_MODEL,
    DEFAULT_THINKING_BUDGET,
    GeminiERGrounder,
)
from robot_mcp_perception.models.metering import CloudBudgetExhaustedError, metered
from robot_mcp_perception.pipelines.common import call_grounder
from robot_mcp_perception.prompt_builder import BadModelAnswerError
from robot_stack_testing.perception.fake_gemini import FakeGemini, serve_fake_gemini

IMAGE = np.zeros((100, 200, 3), np.uint8)
IMAGE[20:60, 40:120] = (200, 30, 30)


@pytest.fixture
def gemini() -> Iterator[FakeGemini]:
    """The strict fake: a request the real API would refuse fails the test with a 400."""
    app = FakeGemini(api_key="test-key")
    with serve_fake_gemini(app):
        yield app
    assert app.rejected == [], app.rejected


@pytest.fixture
async def grounder(gemini: FakeGemini) -> AsyncIterator[GeminiERGrounder]:
    g = GeminiERGrounder(
        api_key=SecretStr("test-key"),
        thinking_budget=128,
        timeout_s=5.0,
        retries=2,
        retry_backoff_s=0.01,
        base_url=gemini.base_url,
    )
    yield g
    await g.aclose()


WELL_FORMED = json.dumps(
    {
        "answer": "a red mug",
        "reasoning": "it is red",
        "targets": [
            {
                "label": "red mug",
                "point": [400, 400],
                "box_2d": [200, 200, 600, 600],
                "confidence": 0.9,
            }
        ],
        "results": [
            {"name": "found", "value": True},
            {"name": "count", "value": "2"},
            {"name": "where", "value": {"y": 500, "x": 250}},
        ],
    }
)
OUTPUTS = [
    SemanticRequest("found", "boolean"),
    SemanticRequest("count", "number"),
    SemanticRequest("where", "position"),
]


async def test_a_well_formed_answer_becomes_pixel_targets_and_typed_outputs(
    gemini: FakeGemini, grounder: GeminiERGrounder
) -> None:
    gemini.replies = [(200, WELL_FORMED)]
    result = await grounder.ground(IMAGE, "the red mug", OUTPUTS)
    [target] = result.targets
    assert target.label == "red mug"
    assert target.box == (40, 20, 120, 60)  # box_2d [ymin, xmin, ymax, xmax] /1000 → pixels
    assert target.points == [(80, 40)]  # [y, x] /1000 → (x, y) pixels
    assert target.confidence == 0.9
    assert target.kind == "object"
    assert result.outputs == {"found": True, "count": 2, "where": {"x": 50.0, "y": 50.0}}
    assert (result.answer, result.reasoning) == ("a red mug", "it is red")


async def test_the_request_carries_model_jpeg_prompt_thinking_and_json_mode(
    gemini: FakeGemini, grounder: GeminiERGrounder
) -> None:
    gemini.replies = [(200, WELL_FORMED)]
    await grounder.ground(IMAGE, "the red mug", OUTPUTS)
    [request] = gemini.requests
    assert request["method"] == "POST"
    assert request["path"] == f"/v1beta/models/{DEFAULT_MODEL}:generateContent"
    assert request["headers"]["x-goog-api-key"] == "test-key"
    parts = request["json"]["contents"][0]["parts"]
    image_part = next(
        p.get("inlineData", p.get("inline_data"))
        for p in parts
        if {"inlineData", "inline_data"} & set(p)
    )
    assert image_part.get("mimeType", image_part.get("mime_type")) == "image/jpeg"
    decoded = cv2.imdecode(
        np.frombuffer(base64.urlsafe_b64decode(image_part["data"] + "=="), np.uint8),
        cv2.IMREAD_COLOR,
    )
    assert decoded is not None
    assert decoded.shape == (100, 200, 3)
    text = next(p["text"] for p in parts if "text" in p)
    assert "Request: the red mug" in text
    assert '"found" (boolean' in text
    assert "box_2d" in text
    config = request["json"]["generationConfig"]
    thinking = config["thinkingConfig"]  # the SDK sends this inner key in snake case
    assert thinking.get("thinkingBudget", thinking.get("thinking_budget")) == 128
    assert config["responseMimeType"] == "application/json"


async def test_a_fenced_answer_with_prose_is_parsed(
    gemini: FakeGemini, grounder: GeminiERGrounder
) -> None:
    gemini.replies = [(200, f"Sure! Here it is:\n```json\n{WELL_FORMED}\n```\nAnything else?")]
    result = await grounder.ground(IMAGE, "the red mug", OUTPUTS)
    assert len(result.targets) == 1
    assert result.outputs["found"] is True


async def test_a_malformed_answer_is_a_model_error_without_retry(
    gemini: FakeGemini, grounder: GeminiERGrounder
) -> None:
    gemini.replies = [(200, "I cannot see anything, sorry.")]
    with pytest.raises(BadModelAnswerError):
        await grounder.ground(IMAGE, "the red mug")
    assert len(gemini.requests) == 1
    gemini.replies = [(200, '"just a string"')]
    with pytest.raises(BadModelAnswerError, match="no JSON"):
        await grounder.ground(IMAGE, "the red mug")


async def test_bad_targets_are_skipped_and_good_ones_kept(
    gemini: FakeGemini, grounder: GeminiERGrounder
) -> None:
    gemini.replies = [
        (
            200,
            json.dumps(
                {
                    "targets": [
                        "nonsense",
                        {"label": "a", "point": [5000, 1]},
                        {"label": "b", "box_2d": [1, 2, 3]},
                        {"label": "c"},
                        {"label": "d", "box_2d": [10, 10, 10, 10]},
                        {"label": "ok", "point": [500, 500]},
                    ]
                }
            ),
        )
    ]
    result = await grounder.ground(IMAGE, "things")
    assert [(t.label, t.points, t.box) for t in result.targets] == [("ok", [(100, 50)], None)]
    gemini.replies = [(200, json.dumps({"targets": "none"}))]
    with pytest.raises(BadModelAnswerError, match="targets must be a list"):
        await grounder.ground(IMAGE, "things")


async def test_server_errors_are_retried_then_answered(
    gemini: FakeGemini, grounder: GeminiERGrounder
) -> None:
    error = {"error": {"code": 503, "message": "overloaded", "status": "UNAVAILABLE"}}
    gemini.replies = [
        (503, error),
        (429, {"error": {"code": 429, "message": "slow down"}}),
        (200, WELL_FORMED),
    ]
    result = await grounder.ground(IMAGE, "the red mug", OUTPUTS)
    assert len(gemini.requests) == 3
    assert result.outputs["found"] is True


async def test_persistent_server_errors_become_a_model_error(
    gemini: FakeGemini, grounder: GeminiERGrounder
) -> None:
    gemini.replies = [(500, {"error": {"code": 500, "message": "internal", "status": "INTERNAL"}})]
    with pytest.raises(ModelError, match="HTTP 500"):
        await grounder.ground(IMAGE, "the red mug")
    assert len(gemini.requests) == 3  # 1 + 2 retries


async def test_client_errors_are_not_retried(
    gemini: FakeGemini, grounder: GeminiERGrounder
) -> None:
    gemini.replies = [
        (400, {"error": {"code": 400, "message": "bad request", "status": "INVALID_ARGUMENT"}})
    ]
    with pytest.raises(ModelError, match="HTTP 400"):
        await grounder.ground(IMAGE, "q")
    gemini.replies = [
        (403, {"error": {"code": 403, "message": "denied", "status": "PERMISSION_DENIED"}})
    ]
    with pytest.raises(ModelUnavailableError, match="refused the API key"):
        await grounder.ground(IMAGE, "q")
    assert len(gemini.requests) == 2


async def test_a_hanging_server_times_out_as_a_model_error(gemini: FakeGemini) -> None:
    gemini.hang_s = 1.0
    gemini.replies = [(200, WELL_FORMED)]
    g = GeminiERGrounder(
        "test-key", timeout_s=0.2, retries=1, retry_backoff_s=0.0, base_url=gemini.base_url
    )
    with pytest.raises(ModelError, match="timed out"):
        await g.ground(IMAGE, "q")
    assert len(gemini.requests) == 2
    await g.aclose()


async def test_an_unreachable_server_is_a_model_error(tcp_port: int) -> None:
    g = GeminiERGrounder(
        "k", timeout_s=2.0, retries=1, retry_backoff_s=0.0, base_url=f"http://127.0.0.1:{tcp_port}"
    )
    with pytest.raises(ModelError, match="unreachable"):
        await g.ground(IMAGE, "q")
    await g.aclose()


async def test_point_returns_every_instance_in_pixels(
    gemini: FakeGemini, grounder: GeminiERGrounder
) -> None:
    gemini.replies = [
        (
            200,
            json.dumps(
                [
                    {"point": [100, 100], "label": "mug"},
                    {"point": [900, 900], "box_2d": [800, 800, 1000, 1000], "label": "box"},
                ]
            ),
        )
    ]
    targets = await grounder.point(IMAGE, "every object")
    assert [(t.label, t.points, t.box) for t in targets] == [
        ("mug", [(20, 10)], None),
        ("box", [(180, 90)], (160, 80, 200, 100)),
    ]
    text = next(
        p["text"] for p in gemini.requests[0]["json"]["contents"][0]["parts"] if "text" in p
    )
    assert "Point to every instance of: every object" in text
    gemini.replies = [(200, json.dumps({"points": [{"point": [500, 500], "label": "x"}]}))]
    assert len(await grounder.point(IMAGE, "x")) == 1


async def test_region_and_describe_modes_shape_the_targets(
    gemini: FakeGemini, grounder: GeminiERGrounder
) -> None:
    gemini.replies = [(200, json.dumps([{"label": "free space", "box_2d": [0, 0, 500, 500]}]))]
    [region] = (await grounder.ground(IMAGE, "free space", mode="region")).targets
    assert region.kind == "region"
    assert region.box == (0, 0, 100, 50)
    gemini.replies = [(200, WELL_FORMED)]
    described = await grounder.ground(
        IMAGE, "what is there", [SemanticRequest("pose", "pose")], mode="describe"
    )
    assert described.targets == []


def test_an_empty_api_key_is_refused_at_start_up() -> None:
    with pytest.raises(ModelUnavailableError, match="GEMINI_API_KEY"):
        GeminiERGrounder(api_key="")
    with pytest.raises(ModelUnavailableError):
        GeminiERGrounder(api_key=SecretStr("  "))


@pytest.mark.parametrize(
    "kwargs", [{"model": ""}, {"timeout_s": 0}, {"retries": -1}, {"jpeg_quality": 0}]
)
def test_bad_settings_are_refused(kwargs: dict[str, Any]) -> None:
    with pytest.raises(ValueError):
        GeminiERGrounder(api_key="k", **kwargs)


def test_the_key_is_not_shown_in_the_grounder_repr() -> None:
    g = GeminiERGrounder(api_key="secret-value")
    assert "secret-value" not in repr(vars(g)["_api_key"])
    assert g.cost_class == "cloud"


class CountingMeter:
    """A run's meter that allows ``limit`` requests."""

    def __init__(self, limit: int) -> None:
        self.limit = limit
        self.charged = 0

    def charge(self) -> bool:
        if self.charged >= self.limit:
            return False
        self.charged += 1
        return True


async def test_every_request_sent_including_retries_is_charged_to_the_runs_meter(
    gemini: FakeGemini, grounder: GeminiERGrounder
) -> None:
    busy = {"error": {"code": 503, "message": "overloaded", "status": "UNAVAILABLE"}}
    gemini.replies = [(503, busy), (503, busy), (200, WELL_FORMED)]
    meter = CountingMeter(limit=10)
    with metered(meter):
        await call_grounder("ground", "s", grounder, {}, grounder.ground(IMAGE, "q"))
    assert meter.charged == len(gemini.requests) == 3


async def test_a_retry_the_budget_has_no_room_for_is_not_sent(
    gemini: FakeGemini, grounder: GeminiERGrounder
) -> None:
    busy = {"error": {"code": 503, "message": "overloaded", "status": "UNAVAILABLE"}}
    gemini.replies = [(503, busy), (200, WELL_FORMED)]
    meter = CountingMeter(limit=1)
    with metered(meter), pytest.raises(CloudBudgetExhaustedError):
        await call_grounder("ground", "s", grounder, {}, grounder.ground(IMAGE, "q"))
    assert len(gemini.requests) == 1


async def test_thinking_is_on_by_default_with_the_documented_budget(gemini: FakeGemini) -> None:
    gemini.replies = [(200, "[]")]
    g = GeminiERGrounder("test-key", base_url=gemini.base_url)
    await g.point(IMAGE, "x")
    await g.aclose()
    thinking = gemini.requests[0]["json"]["generationConfig"]["thinkingConfig"]
    assert thinking == {"thinking_budget": DEFAULT_THINKING_BUDGET}
    assert DEFAULT_THINKING_BUDGET > 0


async def test_a_thinking_level_is_sent_instead_of_a_budget(gemini: FakeGemini) -> None:
    gemini.replies = [(200, "[]")]
    g = GeminiERGrounder(
        "test-key", thinking_level="low", thinking_budget=None, base_url=gemini.base_url
    )
    await g.point(IMAGE, "x")
    await g.aclose()
    thinking = gemini.requests[0]["json"]["generationConfig"]["thinkingConfig"]
    assert thinking == {"thinking_level": "LOW"}


def test_a_thinking_budget_and_level_together_are_refused_at_start_up() -> None:
    with pytest.raises(ValueError, match="thinking_budget or thinking_level"):
        GeminiERGrounder("k", thinking_budget=128, thinking_level="LOW")
    with pytest.raises(ValueError, match="thinking_level"):
        GeminiERGrounder("k", thinking_budget=None, thinking_level="enormous")


async def test_a_position_answered_as_a_y_x_list_is_read_as_y_then_x(
    gemini: FakeGemini, grounder: GeminiERGrounder
) -> None:
    answer = {
        "results": [
            {"name": "where", "value": [800, 250]},
            {"name": "pose", "value": [500, 750, 90]},
            {"name": "said", "value": "[200, 500]"},
        ]
    }
    gemini.replies = [(200, json.dumps(answer))]
    requests = [
        SemanticRequest("where", "position"),
        SemanticRequest("pose", "pose"),
        SemanticRequest("said", "position"),
    ]
    result = await grounder.ground(IMAGE, "q", requests, mode="describe")
    # IMAGE is 200 wide, 100 high: y 800 → 80 px, x 250 → 50 px
    assert result.outputs["where"] == {"x": 50.0, "y": 80.0}
    assert result.outputs["pose"] == {"x": 150.0, "y": 50.0, "z": 0.0, "yaw": 90.0}
    assert result.outputs["said"] == {"x": 100.0, "y": 20.0}


def test_the_worst_case_time_counts_every_attempt_and_the_backoff() -> None:
    g = GeminiERGrounder("k", timeout_s=10.0, retries=2, retry_backoff_s=1.0)
    assert g.worst_case_s == 10.0 * 3 + 1.0 + 2.0


async def test_a_key_the_api_calls_invalid_makes_the_grounder_unavailable_until_a_success(
    gemini: FakeGemini,
) -> None:
    g = GeminiERGrounder("wrong-key", retries=0, base_url=gemini.base_url)
    assert g.readiness() is None
    with pytest.raises(ModelUnavailableError, match="API key"):
        await g.point(IMAGE, "x")
    problem = g.readiness()
    assert problem is not None
    assert "API key" in problem
    await g.aclose()
    gemini.rejected.clear()  # the refusal was the point of this test
