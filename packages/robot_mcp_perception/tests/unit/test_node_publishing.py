"""Publishing of the vision node (spec 000 §9 item 4) on a real rclpy node, in-process."""

from __future__ import annotations

import json
from typing import Any

import numpy as np
import pytest
from ros2_vision_interfaces.msg import StampedString, VisionDetectionArray
from sensor_msgs.msg import Image as ImageMsg

from robot_mcp_perception.conversions import mask_from_image_msg, stamp_to_ns

pytestmark = pytest.mark.ros

STAMP_NS = 1_700_000_123_456_789_000


def _find(**extra: Any) -> dict[str, Any]:
    return {
        "name": "find_object",
        "mode": "ground_and_segment",
        "grounding": "the red mug",
        "outputs": [{"name": "found", "type": "boolean"}, {"name": "count", "type": "number"}],
        "rate_hz": 5.0,
        **extra,
    }


def test_results_keep_the_source_stamp_and_frame_id_and_carry_a_full_frame_mono8_mask(
    start_node: Any,
) -> None:
    harness = start_node()
    detections = harness.probe.subscribe("/vision/find_object/detections", VisionDetectionArray)
    meta = harness.probe.subscribe("/vision/find_object/detections_meta", VisionDetectionArray)
    found = harness.probe.subscribe("/vision/find_object/found", StampedString)
    count = harness.probe.subscribe("/vision/find_object/count", StampedString)
    harness.create(_find(once=True))
    image = np.full((120, 160, 3), 50, dtype=np.uint8)

    harness.source.push(image, stamp_ns=STAMP_NS, frame_id="head_camera")
    harness.pump(lambda: detections and meta and found and count, what="all four topics")

    array = detections[0]
    assert stamp_to_ns(array.header.stamp) == STAMP_NS
    assert array.header.frame_id == "head_camera"
    assert array.skill == "find_object"
    (det,) = array.detections
    assert det.label == "red mug"
    assert (det.box.x_offset, det.box.y_offset, det.box.width, det.box.height) == (40, 30, 80, 60)
    assert det.mask.encoding == "mono8"
    mask = mask_from_image_msg(det.mask)
    assert mask.shape == (120, 160)
    assert mask[60, 80]
    assert not mask[0, 0]
    assert set(np.unique(np.frombuffer(bytes(det.mask.data), np.uint8))) <= {0, 255}
    extra = json.loads(det.extra)
    assert extra["mask_ref"]["url"].endswith(f"/masks/find_object/{STAMP_NS}/0.png")
    (meta_det,) = meta[0].detections
    assert meta_det.label == det.label
    assert meta_det.box == det.box
    assert len(meta_det.mask.data) == 0
    assert stamp_to_ns(meta[0].header.stamp) == STAMP_NS
    assert json.loads(found[0].data) is True
    assert json.loads(count[0].data) == 1
    assert found[0].header.frame_id == "head_camera"
    assert stamp_to_ns(found[0].header.stamp) == STAMP_NS


def test_once_skill_publishes_once_and_disables_itself(start_node: Any) -> None:
    harness = start_node()
    detections = harness.probe.subscribe("/vision/find_object/detections", VisionDetectionArray)
    harness.create(_find(once=True))

    harness.pump(lambda: not harness.node.registry.get("find_object").enabled, what="auto-disable")
    for _ in range(10):
        harness.source.push(np.full((120, 160, 3), 90, dtype=np.uint8))
    harness.pump(lambda: detections, what="the one result")

    state = harness.node.registry.get("find_object")
    assert state.published == 1
    assert state.runs == 1
    _ok, listing = harness.probe.call("list_vision_tasks", {})
    assert listing["skills"][0]["enabled"] is False


def test_overlay_is_published_to_subscribers(start_node: Any) -> None:
    def render(image: Any, result: Any) -> Any:
        out = image.copy()
        out[:, :, 0] = 255
        return out

    harness = start_node(overlay_renderer=render)
    overlays = harness.probe.subscribe("/vision/find_object/overlay", ImageMsg)
    harness.create(_find())
    harness.node.registry.get("find_object")

    harness.pump(lambda: overlays, what="an overlay")

    overlay = overlays[0]
    assert overlay.encoding == "rgb8"
    assert (overlay.height, overlay.width) == (120, 160)
    assert bytes(overlay.data)[0] == 255


def test_default_skills_are_created_at_start_up(start_node: Any, settings_factory: Any) -> None:
    settings = settings_factory(
        node={
            "default_skills": [
                {
                    "name": "scene",
                    "mode": "describe",
                    "outputs": [{"name": "scene", "type": "text"}],
                }
            ]
        }
    )
    harness = start_node(settings=settings)
    texts = harness.probe.subscribe("/vision/scene/scene", StampedString)

    harness.pump(lambda: texts, what="the scene description")

    assert json.loads(texts[0].data) == "a red mug"
    assert "scene" in harness.node.registry


def test_stats_and_latency_topics_are_published(start_node: Any) -> None:
    harness = start_node()
    stats = harness.probe.subscribe("/vision/stats", StampedString, durable=False)
    latency = harness.probe.subscribe("/vision/latency", StampedString, durable=False)
    harness.create(_find())

    harness.pump(lambda: latency, what="a latency sample")
    harness.node.publish_stats()
    harness.pump(lambda: stats, what="stats")

    assert json.loads(latency[0].data)["skill"] == "find_object"
    assert json.loads(stats[-1].data)["skills"]["find_object"]["published"] >= 1
