"""prompt_builder: one prompt for grounding + semantic outputs, a tolerant answer parser."""

from __future__ import annotations

from typing import Any

import pytest
import structlog

from robot_mcp_perception.models.base import ModelError, SemanticRequest
from robot_mcp_perception.prompt_builder import (
    BadModelAnswerError,
    build_point_prompt,
    build_prompt,
    coerce_outputs,
    coerce_value,
    extract_json,
    parse_results,
    semantic_requests,
)
from robot_mcp_perception.skills import SkillOutput

OUTPUTS = [
    SemanticRequest("found", "boolean", "whether the mug is visible"),
    SemanticRequest("n", "number"),
]


def test_the_prompt_holds_question_mode_task_outputs_and_answer_shape() -> None:
    prompt = build_prompt("the red mug", OUTPUTS, "ground_and_segment", max_targets=3)
    assert "Request: the red mug" in prompt
    assert "at most 3 targets" in prompt
    assert '- "found" (boolean: true or false): whether the mug is visible' in prompt
    assert '- "n" (number: a JSON number): n' in prompt
    assert '"results": [{"name": "...", "value": ...}]' in prompt
    assert "[y, x]" in prompt
    assert "box_2d" in prompt
    assert "free, flat, empty area" in build_prompt("space", [], "region")
    assert "Return no targets" in build_prompt("", [], "describe")
    assert "describe the scene" in build_prompt("  ", [], "describe")


def test_the_prompt_refuses_unknown_modes_and_types() -> None:
    with pytest.raises(ValueError, match="unknown mode"):
        build_prompt("q", [], "dance")
    with pytest.raises(ValueError, match="unknown type"):
        build_prompt("q", [SemanticRequest("x", "colour")], "describe")


def test_the_point_prompt_asks_for_every_instance() -> None:
    assert "Point to every instance of: mugs" in build_point_prompt("mugs", 5)
    assert "every distinct object" in build_point_prompt("")


def test_skill_outputs_become_semantic_requests() -> None:
    assert semantic_requests([SkillOutput("a", "text", "d")]) == [SemanticRequest("a", "text", "d")]


@pytest.mark.parametrize(
    "text",
    [
        '{"results": [{"name": "found", "value": true}]}',
        '```json\n{"results": [{"name": "found", "value": true}]}\n```',
        'Here you go: {"results": [{"name": "found", "value": true}]} — hope it helps!',
        '```\n{"results": [{"name": "found", "value": true}]}',
        '{"results": [{"name": "found", "value": true}, {"name": "n", "val',
        '{"results": [{"name": "found", "value": true}, {"name": "n"',
    ],
)
def test_answers_are_parsed_through_fences_prose_and_truncation(text: str) -> None:
    assert parse_results(extract_json(text), OUTPUTS) == {"found": True}


def test_a_truncated_answer_keeps_every_complete_entry() -> None:
    text = (
        '{"answer": "ok", "results": [{"name": "found", "value": "yes"}, '
        '{"name": "n", "value": 4}, {"na'
    )
    assert parse_results(extract_json(text), OUTPUTS) == {"found": True, "n": 4}


@pytest.mark.parametrize("text", ["", "   ", "no json here", '{"a": 1,, "b": }', "{{{"])
def test_answers_without_usable_json_are_model_errors(text: str) -> None:
    with pytest.raises(BadModelAnswerError) as info:
        extract_json(text)
    assert isinstance(info.value, ModelError)


def test_lists_of_results_and_name_value_maps_are_accepted() -> None:
    assert parse_results([{"name": "n", "value": "3"}], OUTPUTS) == {"n": 3}
    assert parse_results({"results": {"found": "no"}}, OUTPUTS) == {"found": False}
    assert parse_results("nonsense", OUTPUTS) == {}
    assert parse_results({"results": ["x", {"name": "other", "value": 1}]}, OUTPUTS) == {}


def test_values_that_cannot_be_coerced_are_logged_and_left_out() -> None:
    with structlog.testing.capture_logs() as logs:
        parsed = parse_results(
            {"results": [{"name": "found", "value": "maybe"}, {"name": "n", "value": 2}]}, OUTPUTS
        )
    assert parsed == {"n": 2}
    [event] = [e for e in logs if e["event"] == "semantic_output_invalid"]
    assert event["output"] == "found"
    assert event["log_level"] == "error"


@pytest.mark.parametrize(
    ("value", "type_", "expected"),
    [
        ("  a mug ", "text", "a mug"),
        (3, "text", "3"),
        ({"a": 1}, "text", '{"a": 1}'),
        (2.5, "number", 2.5),
        ("about 3 mugs", "number", 3),
        ("1.5e2", "number", 150.0),
        ("Yes.", "boolean", True),
        ("not visible", "boolean", False),
        (0, "boolean", False),
        (["cup", " box "], "list", ["cup", "box"]),
        ("cup, box and plate", "list", ["cup", "box", "plate"]),
        (None, "list", []),
        (7, "list", [7]),
        ({"x": 1, "y": "2"}, "position", {"x": 1.0, "y": 2.0}),
        ({"X": 1, "Y": 2, "z": 3}, "position", {"x": 1.0, "y": 2.0, "z": 3.0}),
        ([4, 5], "position", {"x": 4.0, "y": 5.0}),
        ([4, 5, 6], "position", {"x": 4.0, "y": 5.0, "z": 6.0}),
        ("x=4, y=5", "position", {"x": 4.0, "y": 5.0}),
        (
            {"position": {"x": 1, "y": 2}, "theta": 90},
            "pose",
            {"x": 1.0, "y": 2.0, "z": 0.0, "yaw": 90.0},
        ),
        ([1, 2, 30], "pose", {"x": 1.0, "y": 2.0, "z": 0.0, "yaw": 30.0}),
        ([1, 2, 3, 40], "pose", {"x": 1.0, "y": 2.0, "z": 3.0, "yaw": 40.0}),
        ([1, 2], "pose", {"x": 1.0, "y": 2.0, "z": 0.0, "yaw": 0.0}),
    ],
)
def test_values_are_coerced_to_their_declared_type(value: Any, type_: str, expected: Any) -> None:
    assert coerce_value(value, type_) == expected


@pytest.mark.parametrize(
    ("value", "type_"),
    [
        (None, "text"),
        (True, "number"),
        ("many", "number"),
        ([1], "number"),
        ("perhaps", "boolean"),
        (2, "boolean"),
        ({"x": 1}, "position"),
        ([1, 2, 3, 4], "position"),
        ([True, 1], "position"),
        ("left", "pose"),
        (1, "colour"),
    ],
)
def test_values_that_do_not_fit_their_type_are_refused(value: Any, type_: str) -> None:
    with pytest.raises(ValueError):
        coerce_value(value, type_)


def test_coerce_outputs_keeps_only_declared_outputs() -> None:
    assert coerce_outputs({"found": "true", "junk": 1}, OUTPUTS) == {"found": True}
