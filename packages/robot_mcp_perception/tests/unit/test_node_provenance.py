"""Nothing re-used or skipped passes as fresh (issue 13 item 1, ARCHITECTURE §4.1 / §6a):
re-used groundings are marked, skipped cloud stages republish the old result stale with its
original stamp and never segment a new frame with old boxes."""

from __future__ import annotations

import json
import time
from typing import Any

import pytest
from ros2_vision_interfaces.msg import StampedString, VisionDetectionArray

from robot_mcp_perception.conversions import stamp_to_ns
from robot_mcp_perception.models.fakes import FakeSegmenter

pytestmark = pytest.mark.ros

FOUND = [{"name": "found", "type": "boolean", "description": "the mug is visible"}]


def _extra(msg: Any) -> dict[str, Any]:
    return json.loads(msg.extra) if msg.extra else {}


def _det_extra(msg: Any) -> dict[str, Any]:
    return json.loads(msg.detections[0].extra)


def test_a_budget_skip_republishes_the_last_result_stale_and_never_segments_a_new_frame(
    start_node: Any, settings_factory: Any, scene_factory: Any
) -> None:
    settings = settings_factory(
        cost={"max_cloud_calls_per_min": 1, "max_cloud_rate_hz": 30.0, "cloud_requires_gate": True}
    )
    harness = start_node(settings=settings, segmenter=FakeSegmenter())
    detections = harness.probe.subscribe("/vision/grasp/detections", VisionDetectionArray)
    harness.create(
        {"name": "grasp", "mode": "ground_and_segment", "grounding": "mug", "rate_hz": 10}
    )
    harness.pump(lambda: detections, image=scene_factory(40), what="the first result")
    first_stamp = detections[0].header.stamp

    moved_stamps: set[int] = set()
    deadline = time.monotonic() + 10.0
    while not any(
        _det_extra(m).get("stale_reason") == "max_cloud_calls_per_min" for m in detections
    ):
        assert time.monotonic() < deadline, "no stale republish after the budget skip"
        moved_stamps.add(harness.source.push(scene_factory(200)).stamp_ns)
        time.sleep(0.05)
    skips = harness.node.registry.get("grasp").skips
    deadline = time.monotonic() + 10.0
    later = skips["max_cloud_calls_per_min"] + 3
    while skips["max_cloud_calls_per_min"] < later:  # three more ticks on moved frames
        assert time.monotonic() < deadline, "no further budget skips"
        moved_stamps.add(harness.source.push(scene_factory(200)).stamp_ns)
        time.sleep(0.05)

    assert harness.grounder.ground_calls == 1
    assert not {stamp_to_ns(m.header.stamp) for m in detections} & moved_stamps
    stale = next(m for m in detections if _det_extra(m).get("stale"))
    assert stale.header.stamp == first_stamp
    assert _extra(stale)["stale_reason"] == "max_cloud_calls_per_min"
    assert _extra(stale)["checked_stamp"] in moved_stamps


def test_a_result_segmented_on_a_reused_grounding_says_so_and_its_outputs_keep_their_stamp(
    start_node: Any, scene_factory: Any
) -> None:
    harness = start_node()
    detections = harness.probe.subscribe("/vision/grasp/detections", VisionDetectionArray)
    found = harness.probe.subscribe("/vision/grasp/found", StampedString)
    harness.create(
        {
            "name": "grasp",
            "mode": "ground_and_segment",
            "grounding": "mug",
            "rate_hz": 10,
            "outputs": FOUND,
        }
    )
    harness.pump(lambda: len(detections) >= 4, image=scene_factory(40), what="four results")

    grounded = detections[0]
    grounded_ns = stamp_to_ns(grounded.header.stamp)
    assert "grounding_reused" not in _det_extra(grounded)
    reused = [m for m in detections[1:] if m.header.stamp != grounded.header.stamp]
    assert reused
    for msg in reused:
        assert _det_extra(msg)["grounding_reused"] is True
        assert _det_extra(msg)["grounding_stamp"] == grounded_ns
        assert _extra(msg) == {
            "stale": False,
            "grounding_reused": True,
            "grounding_stamp": grounded_ns,
            "grounder": "FakeGrounder",  # who answered the re-used grounding
        }
        assert msg.detections[0].mask.data  # segmented on its own frame
    assert harness.grounder.ground_calls == 1
    assert {stamp_to_ns(m.header.stamp) for m in found} == {grounded_ns}


def test_a_stale_result_without_detections_says_stale_and_why_in_the_result_extra(
    start_node: Any, scene_factory: Any
) -> None:
    harness = start_node()
    meta = harness.probe.subscribe("/vision/look/detections_meta", VisionDetectionArray)
    harness.create(
        {"name": "look", "mode": "describe", "grounding": "what is there", "rate_hz": 10}
    )

    harness.pump(
        lambda: any(_extra(m).get("stale") for m in meta),
        image=scene_factory(40),
        what="a stale republish",
    )

    fresh = meta[0]
    stale = next(m for m in meta if _extra(m).get("stale"))
    assert _extra(fresh) == {"stale": False, "grounder": "FakeGrounder"}
    assert stale.header.stamp == fresh.header.stamp
    assert stale.detections == []
    assert _extra(stale)["stale_reason"] == "scene_unchanged"
    assert _extra(stale)["checked_stamp"] > stamp_to_ns(fresh.header.stamp)


def test_a_prewarmed_grounding_reused_by_a_later_skill_is_marked_with_the_prewarm_frame_stamp(
    start_node: Any, scene_factory: Any
) -> None:
    harness = start_node()
    harness.create(
        {"name": "warm", "mode": "ground_and_segment", "grounding": "mug", "prewarm": True}
    )
    harness.pump(lambda: len(harness.node.prewarm) == 1, image=scene_factory(40), what="prewarm")
    prewarm_frame = harness.source.latest()
    assert prewarm_frame is not None
    detections = harness.probe.subscribe("/vision/grab/detections", VisionDetectionArray)
    harness.create({"name": "grab", "mode": "ground_and_segment", "grounding": "mug", "once": True})
    harness.pump(lambda: detections, image=scene_factory(40), what="the grab result")

    extra = _det_extra(detections[0])
    assert extra["grounding_reused"] is True
    assert extra["grounding_stamp"] <= prewarm_frame.stamp_ns
    assert extra["grounding_stamp"] <= stamp_to_ns(detections[0].header.stamp)
    assert harness.grounder.ground_calls == 1


def test_a_continuous_skill_keeps_segmenting_on_a_prewarmed_grounding_while_the_scene_holds(
    start_node: Any, scene_factory: Any
) -> None:
    harness = start_node()
    harness.create(
        {"name": "warm", "mode": "ground_and_segment", "grounding": "mug", "prewarm": True}
    )
    harness.pump(lambda: len(harness.node.prewarm) == 1, image=scene_factory(40), what="prewarm")
    detections = harness.probe.subscribe("/vision/grasp/detections", VisionDetectionArray)
    harness.create(
        {"name": "grasp", "mode": "ground_and_segment", "grounding": "mug", "rate_hz": 10}
    )

    def reused_fresh() -> list[Any]:
        return [
            m
            for m in detections
            if _det_extra(m).get("grounding_reused") and not _det_extra(m).get("stale")
        ]

    harness.pump(lambda: len(reused_fresh()) >= 3, image=scene_factory(40), what="3 results")

    assert harness.grounder.ground_calls == 1
    assert len({_det_extra(m)["grounding_stamp"] for m in reused_fresh()}) == 1
