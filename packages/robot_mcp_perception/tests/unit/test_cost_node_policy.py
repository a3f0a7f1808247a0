"""Cost policy, watch gate and prewarm on a live node (spec 000 §9 items 5, 6, 7)."""

from __future__ import annotations

import json
from typing import Any

import pytest
from ros2_vision_interfaces.msg import StampedString, VisionDetectionArray

from robot_mcp_perception.models.base import GroundingResult
from robot_mcp_perception.models.fakes import FakeGrounder

pytestmark = pytest.mark.ros


def _skipped(events: list[dict[str, Any]], reason: str | None = None) -> list[dict[str, Any]]:
    return [
        e
        for e in events
        if e["event"] == "cloud_call_skipped" and (reason is None or e["reason"] == reason)
    ]


def _skips(harness: Any, skill: str, reason: str) -> int:
    """How many of the skill's ticks the engine decided to skip for ``reason``."""
    return int(harness.node.registry.get(skill).skips[reason])


WATCH = {
    "name": "door",
    "mode": "describe",
    "grounding": "is the door open?",
    "outputs": [{"name": "found", "type": "boolean"}],
    "watch": {"output": "found", "equals": True},
    "rate_hz": 10.0,
}


def test_identical_frames_suppress_grounder_calls_and_a_changed_frame_escalates(
    start_node: Any, settings_factory: Any, scene_factory: Any, log_events: list[dict[str, Any]]
) -> None:
    settings = settings_factory(cost={"max_cloud_rate_hz": 20.0})
    harness = start_node(settings=settings)
    found = harness.probe.subscribe("/vision/door/found", StampedString)
    harness.create(WATCH)
    still = scene_factory(40)

    harness.pump(lambda: found, image=still, what="the first answer")
    harness.pump(  # ticks on the still scene, each one decided
        lambda: _skips(harness, "door", "scene_unchanged") >= 5,
        image=still,
        what="five ticks on the still scene",
    )
    calls_on_still_scene = harness.grounder.ground_calls
    harness.pump(
        lambda: harness.grounder.ground_calls > calls_on_still_scene,
        image=scene_factory(200),
        what="escalation on a changed frame",
    )

    assert calls_on_still_scene == 1
    assert _skipped(log_events, "scene_unchanged")
    assert harness.grounder.ground_calls == 2


def test_continuous_cloud_skill_skips_when_over_the_per_minute_budget(
    start_node: Any, settings_factory: Any, scene_factory: Any, log_events: list[dict[str, Any]]
) -> None:
    settings = settings_factory(
        cost={"max_cloud_calls_per_min": 2, "max_cloud_rate_hz": 30.0, "cloud_requires_gate": False}
    )
    harness = start_node(settings=settings)
    meta = harness.probe.subscribe("/vision/scene/detections_meta", VisionDetectionArray)
    harness.create({"name": "scene", "mode": "region", "grounding": "mug", "rate_hz": 10})

    harness.pump(lambda: _skipped(log_events, "max_cloud_calls_per_min"), what="a budget skip")
    harness.pump(lambda: any(_stale(m) for m in meta), what="a stale republish")

    assert harness.grounder.ground_calls == 2
    assert harness.node.policy.budget.used() == 2


def _stale(msg: Any) -> bool:
    return bool(msg.detections) and json.loads(msg.detections[0].extra).get("stale") is True


def test_skipped_cloud_stage_republishes_the_last_result_stale_with_its_original_stamp(
    start_node: Any, scene_factory: Any, log_events: list[dict[str, Any]]
) -> None:
    harness = start_node()
    meta = harness.probe.subscribe("/vision/spot/detections_meta", VisionDetectionArray)
    harness.create({"name": "spot", "mode": "region", "grounding": "free space", "rate_hz": 10})
    still = scene_factory(40)

    harness.pump(lambda: any(_stale(m) for m in meta), image=still, what="a stale republish")

    fresh = next(m for m in meta if not _stale(m))
    stale = next(m for m in meta if _stale(m))
    assert stale.header.stamp == fresh.header.stamp
    extra = json.loads(stale.detections[0].extra)
    assert extra["reason"] in {"scene_unchanged", "max_cloud_rate_hz"}
    assert _skipped(log_events)


def test_once_skill_always_fires_once_even_with_no_budget_left(
    start_node: Any, settings_factory: Any
) -> None:
    settings = settings_factory(cost={"max_cloud_calls_per_min": 0})
    harness = start_node(settings=settings)
    detections = harness.probe.subscribe("/vision/find/detections", VisionDetectionArray)
    harness.create({"name": "find", "mode": "ground_and_segment", "grounding": "mug", "once": True})

    harness.pump(lambda: detections, what="the once result")

    assert harness.grounder.ground_calls == 1
    assert detections[0].detections[0].label == "red mug"


def test_local_stages_keep_running_at_rate_while_cloud_grounding_is_skipped(
    start_node: Any, scene_factory: Any, log_events: list[dict[str, Any]]
) -> None:
    harness = start_node()
    detections = harness.probe.subscribe("/vision/grasp/detections", VisionDetectionArray)
    harness.create(
        {"name": "grasp", "mode": "ground_and_segment", "grounding": "mug", "rate_hz": 10}
    )

    harness.pump(lambda: len(detections) >= 6, image=scene_factory(40), what="six results")

    assert harness.grounder.ground_calls == 1
    fresh_masks = [m for m in detections if m.detections and m.detections[0].mask.data]
    assert len(fresh_masks) >= 6
    assert harness.node.registry.get("grasp").runs >= 6
    assert _skipped(log_events, "scene_unchanged") or _skipped(log_events, "max_cloud_rate_hz")


def test_local_grounder_is_never_throttled(
    start_node: Any, settings_factory: Any, scene_factory: Any
) -> None:
    settings = settings_factory(cost={"max_cloud_calls_per_min": 0})
    harness = start_node(settings=settings, grounder=FakeGrounder(_result(), cost_class="local"))
    harness.create({"name": "local", "mode": "describe", "rate_hz": 10})

    harness.pump(
        lambda: harness.grounder.ground_calls >= 5, image=scene_factory(40), what="5 calls"
    )

    assert harness.node.policy.budget.total == 0


def _result() -> GroundingResult:
    return GroundingResult(answer="ok", outputs={})


def test_ambient_scene_keeps_the_buffer_warm_with_calls_only_on_frame_change(
    start_node: Any, settings_factory: Any, scene_factory: Any
) -> None:
    settings = settings_factory(
        cost={"ambient_scene": {"enabled": True, "rate_hz": 10.0}, "max_cloud_rate_hz": 30.0}
    )
    described = GroundingResult(
        answer="a red mug on a table",
        outputs={"scene_description": "a red mug on a table", "scene_objects": ["red mug"]},
    )
    harness = start_node(settings=settings, grounder=FakeGrounder(described))
    description = harness.probe.subscribe("/vision/ambient_scene/scene_description", StampedString)
    objects = harness.probe.subscribe("/vision/ambient_scene/scene_objects", StampedString)
    meta = harness.probe.subscribe("/vision/ambient_scene/detections_meta", VisionDetectionArray)

    harness.pump(lambda: description and objects, image=scene_factory(40), what="the description")
    harness.pump(
        lambda: any(_result_extra(m).get("stale") for m in meta),
        image=scene_factory(40),
        what="an unchanged-scene republish",
    )
    calls_still = harness.grounder.ground_calls
    harness.pump(
        lambda: harness.grounder.ground_calls == 2, image=scene_factory(220), what="change"
    )

    assert json.loads(description[0].data) == "a red mug on a table"
    assert json.loads(objects[0].data) == ["red mug"]
    unchanged = next(m for m in meta if _result_extra(m).get("stale"))
    assert _result_extra(unchanged)["stale_reason"] == "scene_unchanged"
    assert unchanged.header.stamp == description[0].header.stamp  # "unchanged since" that
    assert _result_extra(unchanged)["checked_stamp"] > _ns(unchanged.header.stamp)
    assert calls_still == 1
    assert harness.node.registry.get("ambient_scene").always_gated is True


def _result_extra(msg: Any) -> dict[str, Any]:
    return json.loads(msg.extra) if msg.extra else {}


def _ns(stamp: Any) -> int:
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def test_prewarm_grounds_once_and_a_later_skill_reuses_it_within_the_ttl(
    start_node: Any, scene_factory: Any
) -> None:
    harness = start_node()
    grounding = "the red mug"
    harness.create(
        {"name": "warm", "mode": "ground_and_segment", "grounding": grounding, "prewarm": True}
    )
    warm_meta = harness.probe.subscribe("/vision/warm/detections_meta", VisionDetectionArray)
    harness.pump(lambda: len(harness.node.prewarm) == 1, image=scene_factory(40), what="prewarm")
    assert harness.node.registry.get("warm").enabled is False

    detections = harness.probe.subscribe("/vision/grab/detections", VisionDetectionArray)
    harness.create(
        {"name": "grab", "mode": "ground_and_segment", "grounding": grounding, "once": True}
    )
    harness.pump(lambda: detections, image=scene_factory(40), what="the grab result")

    assert harness.grounder.ground_calls == 1
    assert harness.node.prewarm.hits == 1
    assert detections[0].detections[0].mask.data
    assert warm_meta == []


def test_a_prewarm_once_skill_as_skill_control_sends_it_publishes_nothing_and_is_reused(
    start_node: Any, scene_factory: Any
) -> None:
    harness = start_node()
    find_object = {
        "mode": "ground_and_segment",
        "grounding": "the red mug",
        "segment": True,
        "outputs": [{"name": "found", "type": "boolean", "description": "the mug is visible"}],
    }
    warm_topics = [
        harness.probe.subscribe(f"/vision/prewarm_find_object/{topic}", msg_type)
        for topic, msg_type in (
            ("detections", VisionDetectionArray),
            ("detections_meta", VisionDetectionArray),
            ("found", StampedString),
        )
    ]
    harness.create({**find_object, "name": "prewarm_find_object", "prewarm": True, "once": True})
    harness.pump(lambda: len(harness.node.prewarm) == 1, image=scene_factory(40), what="prewarm")
    warm = harness.node.registry.get("prewarm_find_object")
    assert warm.enabled is False
    assert (warm.runs, warm.published) == (1, 0)
    assert harness.grounder.ground_calls == 1

    detections = harness.probe.subscribe("/vision/find_object/detections", VisionDetectionArray)
    found = harness.probe.subscribe("/vision/find_object/found", StampedString)
    harness.create({**find_object, "name": "find_object", "once": True})
    harness.pump(lambda: detections and found, image=scene_factory(40), what="the find result")

    assert harness.grounder.ground_calls == 1
    assert harness.node.prewarm.hits == 1
    assert [d.label for d in detections[0].detections] == ["red mug"]
    assert detections[0].detections[0].mask.data
    assert json.loads(found[0].data) is True
    assert harness.node.registry.get("find_object").enabled is False
    assert warm_topics == [[], [], []]


def test_a_prewarmed_grounding_is_not_reused_on_a_frame_showing_another_scene(
    start_node: Any, scene_factory: Any
) -> None:
    harness = start_node()
    harness.create(
        {"name": "warm", "mode": "ground_and_segment", "grounding": "mug", "prewarm": True}
    )
    harness.pump(lambda: len(harness.node.prewarm) == 1, image=scene_factory(40), what="prewarm")

    harness.source.push(scene_factory(200))  # the robot moved: the camera shows another view
    detections = harness.probe.subscribe("/vision/grab/detections", VisionDetectionArray)
    harness.create({"name": "grab", "mode": "ground_and_segment", "grounding": "mug", "once": True})
    harness.pump(lambda: detections, image=scene_factory(200), what="the grab result")

    assert harness.grounder.ground_calls == 2  # grounded again on the new view
    assert (harness.node.prewarm.hits, harness.node.prewarm.scene_changed) == (0, 1)


def test_prewarm_entry_expires_after_the_ttl(
    start_node: Any, settings_factory: Any, scene_factory: Any
) -> None:
    harness = start_node(settings=settings_factory(prewarm={"prewarm_ttl_s": 0.05}))
    harness.create({"name": "warm", "mode": "describe", "grounding": "x", "prewarm": True})
    harness.pump(lambda: not harness.node.registry.get("warm").enabled, what="prewarm done")

    harness.pump(lambda: len(harness.node.prewarm) == 0, what="expiry")

    harness.create({"name": "late", "mode": "describe", "grounding": "x", "once": True})
    harness.pump(lambda: harness.grounder.ground_calls == 2, what="a fresh grounding")


def test_segment_all_tile_and_ground_requests_each_count_and_a_run_that_does_not_fit_is_skipped(
    start_node: Any, settings_factory: Any, scene_factory: Any, log_events: list[dict[str, Any]]
) -> None:
    settings = settings_factory(
        cost={"max_cloud_calls_per_min": 7, "max_cloud_rate_hz": 30.0, "cloud_requires_gate": False}
    )
    harness = start_node(settings=settings)
    harness.create(
        {
            "name": "everything",
            "mode": "segment_all",
            "segment": True,
            "rate_hz": 10,
            "outputs": [{"name": "count", "type": "number"}],
        }
    )

    harness.pump(lambda: _skipped(log_events, "max_cloud_calls_per_min"), what="a budget skip")
    skipped = _skips(harness, "everything", "max_cloud_calls_per_min")
    harness.pump(  # later ticks, each one decided: none may fit what is left of the budget
        lambda: _skips(harness, "everything", "max_cloud_calls_per_min") >= skipped + 3,
        image=scene_factory(40),
        what="three more ticks",
    )

    assert (harness.grounder.point_calls, harness.grounder.ground_calls) == (4, 1)  # 2x2 tiles
    assert harness.node.policy.budget.used() == 5
