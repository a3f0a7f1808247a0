"""A live node behind a grounder chain: the fallback's results say so; a spent cloud budget is
answered on board without a cloud request; with no fallback a failed look says "cannot see"."""

from __future__ import annotations

import json
from typing import Any

import pytest
from ros2_vision_interfaces.msg import VisionDetectionArray

from robot_mcp_perception.models.base import ModelError
from robot_mcp_perception.models.chain import FallbackGrounder
from robot_mcp_perception.models.fakes import FakeGrounder

pytestmark = pytest.mark.ros

FIND = {
    "name": "find",
    "mode": "ground_and_segment",
    "grounding": "the mug",
    "segment": True,
    "once": True,
}


def _extra(msg: Any) -> dict[str, Any]:
    return json.loads(msg.extra) if msg.extra else {}


def _chain(primary: FakeGrounder, mug_result: Any) -> FallbackGrounder:
    primary.name = "gemini_er"
    fallback = FakeGrounder(mug_result, cost_class="local")
    fallback.name = "owlv2"
    return FallbackGrounder(primary, fallback)


def test_a_result_the_fallback_answered_says_who_answered_and_why(
    start_node: Any, scene_factory: Any, mug_result: Any
) -> None:
    grounder = _chain(FakeGrounder(error=ModelError("unreachable", "network")), mug_result)
    harness = start_node(grounder=grounder)
    meta = harness.probe.subscribe("/vision/find/detections_meta", VisionDetectionArray)
    harness.create(FIND)
    harness.pump(lambda: meta, image=scene_factory(40), what="a result")

    marks = {"grounder": "owlv2", "grounder_fallback": True, "fallback_reason": "network"}
    assert marks.items() <= _extra(meta[0]).items()
    assert marks.items() <= json.loads(meta[0].detections[0].extra).items()
    assert meta[0].detections[0].label == "red mug"


def test_a_spent_cloud_budget_is_answered_on_board_without_a_cloud_request(
    start_node: Any, settings_factory: Any, scene_factory: Any, mug_result: Any
) -> None:
    primary = FakeGrounder(mug_result)
    settings = settings_factory(cost={"max_cloud_calls_per_min": 0, "cloud_requires_gate": False})
    harness = start_node(grounder=_chain(primary, mug_result), settings=settings)
    meta = harness.probe.subscribe("/vision/look/detections_meta", VisionDetectionArray)
    harness.create({**FIND, "name": "look", "once": False, "rate_hz": 5.0})
    harness.pump(lambda: meta, image=scene_factory(40), what="a result")

    assert primary.ground_calls == 0
    assert _extra(meta[0])["fallback_reason"] == "budget"
    assert harness.node.policy.budget.total == 0


def test_without_a_fallback_a_failed_look_says_cannot_see_never_nothing_found(
    start_node: Any, scene_factory: Any
) -> None:
    harness = start_node(grounder=FakeGrounder(error=ModelError("HTTP 503", "server_error")))
    meta = harness.probe.subscribe("/vision/find/detections_meta", VisionDetectionArray)
    harness.create(FIND)
    harness.pump(lambda: meta, image=scene_factory(40), what="a cannot-see result")

    extra = _extra(meta[0])
    assert extra["cannot_see"] is True
    assert extra["cannot_see_reason"] == "server_error"
    assert extra["stale"] is True  # not a fresh "nothing there"
    assert meta[0].detections == []
