"""Services of the vision node (spec 000 §9 item 3) on a real rclpy node, in-process."""

from __future__ import annotations

import json
from typing import Any

import pytest

pytestmark = pytest.mark.ros

FIND = {
    "name": "find_object",
    "mode": "ground_and_segment",
    "grounding": "the red mug",
    "outputs": [{"name": "found", "type": "boolean"}],
    "rate_hz": 5.0,
}


def test_create_registers_the_skill_and_its_publishers(start_node: Any) -> None:
    harness = start_node()

    reply = harness.create(FIND)

    assert reply == {
        "name": "find_object",
        "topics": {
            "detections": "/vision/find_object/detections",
            "detections_meta": "/vision/find_object/detections_meta",
            "overlay": "/vision/find_object/overlay",
            "outputs": {"found": "/vision/find_object/found"},
        },
    }
    published = {name for name, _ in harness.node.get_topic_names_and_types()}
    assert (
        set(reply["topics"]["outputs"].values())
        | {
            "/vision/find_object/detections",
            "/vision/find_object/detections_meta",
            "/vision/find_object/overlay",
        }
        <= published
    )


def test_list_reports_skills_enabled_topics_and_watch_block(start_node: Any) -> None:
    harness = start_node()
    harness.create(
        {
            "name": "watch_door",
            "mode": "describe",
            "outputs": [{"name": "triggered", "type": "boolean"}],
            "watch": {"output": "triggered", "equals": True},
        }
    )

    ok, reply = harness.probe.call("list_vision_tasks", {})

    assert ok
    (skill,) = reply["skills"]
    assert skill["name"] == "watch_door"
    assert skill["enabled"] is True
    assert skill["watch"] == {"output": "triggered", "equals": True}
    assert skill["topics"]["outputs"] == {"triggered": "/vision/watch_door/triggered"}


def test_manage_disable_enable_and_delete(start_node: Any) -> None:
    harness = start_node()
    harness.create(FIND)

    ok, reply = harness.probe.call(
        "manage_vision_task", {"task_name": "find_object", "action": "disable"}
    )
    assert ok
    assert reply["enabled"] is False
    assert harness.node.registry.get("find_object").enabled is False

    ok, reply = harness.probe.call(
        "manage_vision_task", {"task_name": "find_object", "action": "enable"}
    )
    assert ok
    assert reply["enabled"] is True

    ok, reply = harness.probe.call(
        "manage_vision_task", {"task_name": "find_object", "action": "delete"}
    )
    assert ok
    assert reply["deleted"] is True
    assert "find_object" not in harness.node.registry
    node_topics = {name for name, _ in harness.node.get_topic_names_and_types()}
    assert "/vision/find_object/detections" not in node_topics
    ok, listing = harness.probe.call("list_vision_tasks", {})
    assert listing == {"skills": []}


BAD_REQUESTS = [
    ("create_vision_task", "{not json", "invalid_json"),
    ("create_vision_task", "[]", "invalid_request"),
    ("create_vision_task", json.dumps({"name": 3, "mode": "describe"}), "invalid_type"),
    ("create_vision_task", json.dumps({"name": "s", "mode": "dance"}), "invalid_mode"),
    ("create_vision_task", json.dumps({"name": "", "mode": "describe"}), "invalid_name"),
    ("create_vision_task", json.dumps({"name": "a/b", "mode": "describe"}), "invalid_name"),
    ("create_vision_task", json.dumps({"name": "a b", "mode": "describe"}), "invalid_name"),
    (
        "create_vision_task",
        json.dumps({"name": "s", "mode": "describe", "pad": "x" * 200_000}),
        "payload_too_large",
    ),
    (
        "create_vision_task",
        json.dumps({"name": "s", "mode": "describe", "outputs": [{"name": "o", "type": "blob"}]}),
        "invalid_output_type",
    ),
    (
        "create_vision_task",
        json.dumps({"name": "s", "mode": "describe", "rate_hz": 0}),
        "invalid_rate",
    ),
    (
        "create_vision_task",
        json.dumps({"name": "s", "mode": "describe", "rate_hz": -1}),
        "invalid_rate",
    ),
    ("create_vision_task", json.dumps(FIND), "duplicate_name"),
    ("manage_vision_task", json.dumps({"task_name": "nope", "action": "enable"}), "unknown_skill"),
    (
        "manage_vision_task",
        json.dumps({"task_name": "find_object", "action": "explode"}),
        "invalid_action",
    ),
    ("manage_vision_task", json.dumps({"action": "delete"}), "missing_field"),
    ("list_vision_tasks", "{oops", "invalid_json"),
]


def test_bad_requests_are_rejected_with_a_code_and_the_node_keeps_serving(start_node: Any) -> None:
    harness = start_node()
    harness.create(FIND)

    codes = []
    for service, payload, expected in BAD_REQUESTS:
        ok, reply = harness.probe.call(service, payload)
        assert ok is False, (service, payload[:60])
        assert set(reply) == {"error", "detail"}
        assert reply["detail"]
        codes.append((reply["error"], expected))

    assert all(got == expected for got, expected in codes), codes
    ok, listing = harness.probe.call("list_vision_tasks", "")
    assert ok
    assert [s["name"] for s in listing["skills"]] == ["find_object"]
