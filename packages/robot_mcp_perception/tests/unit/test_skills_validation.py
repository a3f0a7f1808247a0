"""skills.py: (de)serialisation and validation of skills (spec 000 §9 item 1)."""

from __future__ import annotations

import json

import pytest

from robot_mcp_perception.skills import (
    MAX_SKILL_JSON_BYTES,
    Skill,
    SkillError,
    SkillOutput,
    WatchSpec,
)

FIND_OBJECT = {
    "name": "find_object",
    "description": "Locate and segment a queried object.",
    "mode": "ground_and_segment",
    "grounding": "the scissors lying on top of the pile",
    "segment": True,
    "outputs": [{"name": "found", "type": "boolean", "description": "whether it is visible"}],
    "rate_hz": 2.0,
    "once": True,
}


def test_spec_example_skill_parses_into_the_dataclasses() -> None:
    skill = Skill.from_json(json.dumps(FIND_OBJECT))

    assert skill.name == "find_object"
    assert skill.mode == "ground_and_segment"
    assert skill.segment is True
    assert skill.outputs == (SkillOutput("found", "boolean", "whether it is visible"),)
    assert skill.rate_hz == 2.0
    assert skill.once is True
    assert skill.watch is None
    assert skill.prewarm is False


def test_skill_survives_a_json_round_trip() -> None:
    skill = Skill.from_dict(
        {
            "name": "watch_door",
            "mode": "describe",
            "outputs": [{"name": "triggered", "type": "boolean"}],
            "watch": {"output": "triggered", "equals": True},
            "prewarm": True,
        }
    )

    assert Skill.from_json(skill.to_json()) == skill
    assert skill.watch == WatchSpec("triggered", True)


def test_missing_optional_fields_take_their_defaults() -> None:
    skill = Skill.from_dict({"name": "scene", "mode": "describe"})

    assert skill.rate_hz is None
    assert skill.outputs == ()
    assert skill.segments is False


def test_segment_all_segments_by_default() -> None:
    assert Skill.from_dict({"name": "all", "mode": "segment_all"}).segments is True


@pytest.mark.parametrize(
    ("payload", "code"),
    [
        ("{not json", "invalid_json"),
        ("[1, 2]", "invalid_request"),
        ('"a string"', "invalid_request"),
        ("x" * (MAX_SKILL_JSON_BYTES + 1), "payload_too_large"),
        (json.dumps({"mode": "describe"}), "missing_field"),
        (json.dumps({"name": "", "mode": "describe"}), "invalid_name"),
        (json.dumps({"name": "a/b", "mode": "describe"}), "invalid_name"),
        (json.dumps({"name": "a b", "mode": "describe"}), "invalid_name"),
        (json.dumps({"name": "9lives", "mode": "describe"}), "invalid_name"),
        (json.dumps({"name": 5, "mode": "describe"}), "invalid_type"),
        (json.dumps({"name": "s"}), "missing_field"),
        (json.dumps({"name": "s", "mode": "dance"}), "invalid_mode"),
        (json.dumps({"name": "s", "mode": "region"}), "missing_grounding"),
        (json.dumps({"name": "s", "mode": "describe", "rate_hz": 0}), "invalid_rate"),
        (json.dumps({"name": "s", "mode": "describe", "rate_hz": -2}), "invalid_rate"),
        (json.dumps({"name": "s", "mode": "describe", "rate_hz": 1e9}), "invalid_rate"),
        (json.dumps({"name": "s", "mode": "describe", "rate_hz": "fast"}), "invalid_type"),
        (json.dumps({"name": "s", "mode": "describe", "rate_hz": True}), "invalid_type"),
        (json.dumps({"name": "s", "mode": "describe", "once": "yes"}), "invalid_type"),
        (json.dumps({"name": "s", "mode": "describe", "outputs": {}}), "invalid_type"),
        (json.dumps({"name": "s", "mode": "describe", "outputs": [1]}), "invalid_type"),
        (
            json.dumps(
                {"name": "s", "mode": "describe", "outputs": [{"name": "x", "type": "blob"}]}
            ),
            "invalid_output_type",
        ),
        (
            json.dumps(
                {"name": "s", "mode": "describe", "outputs": [{"name": "a b", "type": "text"}]}
            ),
            "invalid_name",
        ),
        (
            json.dumps(
                {"name": "s", "mode": "describe", "outputs": [{"name": "overlay", "type": "text"}]}
            ),
            "invalid_name",
        ),
        (
            json.dumps(
                {
                    "name": "s",
                    "mode": "describe",
                    "outputs": [{"name": "x", "type": "text"}, {"name": "x", "type": "list"}],
                }
            ),
            "duplicate_output",
        ),
        (
            json.dumps({"name": "s", "mode": "describe", "watch": {"output": "nope"}}),
            "invalid_watch",
        ),
        (json.dumps({"name": "s", "mode": "describe", "watch": True}), "invalid_type"),
        (json.dumps({"name": "s", "mode": "describe", "colour": "red"}), "unknown_field"),
        (json.dumps({"name": "s", "mode": "describe", "grounding": "g" * 5000}), "invalid_value"),
    ],
)
def test_bad_skill_json_is_rejected_with_a_stable_code(payload: str, code: str) -> None:
    with pytest.raises(SkillError) as caught:
        Skill.from_json(payload)

    assert caught.value.code == code
    assert json.loads(caught.value.to_json()) == {"error": code, "detail": caught.value.detail}
    assert caught.value.detail


@pytest.mark.parametrize(
    ("output_type", "equals"), [("text", True), ("number", 1), ("list", True), ("boolean", "yes")]
)
def test_a_watcher_must_watch_a_boolean_output_for_a_boolean_value(
    output_type: str, equals: object
) -> None:
    payload = {
        "name": "watch_door",
        "mode": "describe",
        "outputs": [{"name": "door", "type": output_type}],
        "watch": {"output": "door", "equals": equals},
    }
    with pytest.raises(SkillError) as caught:
        Skill.from_dict(payload)

    assert caught.value.code == "invalid_watch"
    assert "boolean" in caught.value.detail
