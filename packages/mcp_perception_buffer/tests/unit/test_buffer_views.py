import json
from typing import Any

from mcp_perception_buffer.buffer import RollingBuffer
from mcp_perception_buffer.views import detection_view, latest_view, scene_view

DET = {
    "label": "scissors",
    "score": 0.91,
    "kind": "object",
    "box": {"x": 1, "y": 2, "width": 3, "height": 4},
    "point": {"x": 2.5, "y": 4.0},
    "extra": {"mask_url": "http://127.0.0.1:9112/masks/find/1.png", "model": "offline"},
}


def test_a_detection_carries_a_mask_ref_and_never_pixels() -> None:
    view = detection_view("find", 12.5, 0, DET)
    assert view["mask_ref"] == {
        "topic": "/vision/find/detections",
        "stamp": 12.5,
        "index": 0,
        "url": "http://127.0.0.1:9112/masks/find/1.png",
    }
    assert view["extra"] == {"model": "offline"}
    assert view["stale"] is False
    assert "mask" not in view


def test_the_stale_flag_and_reason_of_a_republished_result_are_surfaced() -> None:
    det = {
        **DET,
        "extra": {"stale": True, "reason": "over_budget", "mask_ref": {"url": "http://x/m.png"}},
    }
    view = detection_view("find", 1.0, 3, det)
    assert view["stale"] is True
    assert view["stale_reason"] == "over_budget"  # an older node's "reason" key
    assert view["mask_ref"]["url"] == "http://x/m.png"
    assert view["mask_ref"]["index"] == 3


def test_a_huge_extra_is_truncated_rather_than_forwarded() -> None:
    det = {**DET, "extra": {"data": list(range(5000))}}
    view = detection_view("find", 1.0, 0, det)
    assert "extra" not in view
    assert view["extra_truncated"] is True
    assert view["mask_ref"]["url"] is None


def test_what_do_you_see_is_cold_with_a_recipe_when_nothing_is_buffered() -> None:
    view = scene_view([], now=100.0, stale_after_s=10.0)
    assert view["mode"] == "cold"
    assert view["stale"] is True
    assert view["stamp"] is None
    assert "describe_scene" in view["hint"]
    assert "wait_for_result" in view["hint"]


def test_what_do_you_see_is_warm_with_the_latest_description_and_detections() -> None:
    buffer = RollingBuffer(clock=lambda: 100.0)
    buffer.add_output("scene", "scene_description", "a desk with a mug", 95.0)
    buffer.add_output("scene", "scene_objects", ["mug", "laptop"], 95.0)
    buffer.add_output("scene2", "scene_description", "older", 90.0)
    buffer.add_result("find", 98.0, [DET])
    buffers = [b for s in buffer.skills() if (b := buffer.snapshot(s))]
    view = scene_view(buffers, now=100.0, stale_after_s=10.0)
    assert view["mode"] == "warm"
    assert view["scene_description"]["value"] == "a desk with a mug"
    assert view["scene_objects"]["value"] == ["mug", "laptop"]
    assert view["stamp"] == 98.0
    assert view["age_s"] == 2.0
    assert view["skills"][0]["detections"][0]["label"] == "scissors"
    assert "data" not in json.dumps(view)


def test_what_do_you_see_is_stale_when_everything_is_old() -> None:
    buffer = RollingBuffer(clock=lambda: 100.0)
    buffer.add_result("find", 50.0, [DET])
    view = scene_view([buffer.snapshot("find")], now=100.0, stale_after_s=10.0)  # type: ignore[list-item]
    assert view["mode"] == "stale"
    assert view["stale"] is True
    assert "10 s" in view["hint"]


def test_a_result_republished_stale_is_reported_stale_with_the_nodes_reason() -> None:
    buffer = RollingBuffer(clock=lambda: 100.0)
    marks = {"stale": True, "stale_reason": "cloud_budget_exhausted"}
    buffer.add_result("find", 99.0, [{**DET, "extra": marks}], meta=marks)
    buffer.add_output("find", "found", True, 99.0)  # republished with its original stamp
    view = latest_view(buffer.snapshot("find"), now=100.0, stale_after_s=10.0)  # type: ignore[arg-type]
    assert (view["stale"], view["stale_reason"]) == (True, "cloud_budget_exhausted")
    assert view["detections"][0]["stale_reason"] == "cloud_budget_exhausted"
    assert view["outputs"]["found"]["stale"] is True
    assert view["outputs"]["found"]["stale_reason"] == "cloud_budget_exhausted"


def test_a_result_without_detections_says_stale_through_its_result_extra() -> None:
    buffer = RollingBuffer(clock=lambda: 100.0)
    buffer.add_result("desc", 99.5, [], meta={"stale": True, "stale_reason": "rate_limited"})
    view = latest_view(buffer.snapshot("desc"), now=100.0, stale_after_s=10.0)  # type: ignore[arg-type]
    assert (view["stale"], view["stale_reason"]) == (True, "rate_limited")


def test_a_result_on_a_reused_grounding_says_so() -> None:
    buffer = RollingBuffer(clock=lambda: 100.0)
    extra = {"grounding_reused": True, "grounding_stamp": 97_000_000_000}
    buffer.add_result("find", 99.0, [{**DET, "extra": extra}], meta=extra)
    view = latest_view(buffer.snapshot("find"), now=100.0, stale_after_s=10.0)  # type: ignore[arg-type]
    assert view["stale"] is False
    assert (view["grounding_reused"], view["grounding_stamp"]) == (True, 97.0)
    assert view["detections"][0]["grounding_reused"] is True


def unchanged_scene(now: float, checked_ns: int, received_at: float) -> list[Any]:
    buffer = RollingBuffer(clock=lambda: received_at)
    buffer.add_output("ambient", "scene_description", "a desk with a mug", 40.0)
    buffer.add_output("ambient", "scene_objects", ["mug"], 40.0)
    meta = {"stale": True, "stale_reason": "scene_unchanged", "checked_stamp": checked_ns}
    buffer.add_result("ambient", 40.0, [], meta=meta)
    return [buffer.snapshot("ambient")]


def test_an_unchanged_scene_still_checked_is_warm_unchanged_since_its_stamp() -> None:
    view = scene_view(unchanged_scene(100.0, 99_000_000_000, 99.0), now=100.0, stale_after_s=10.0)
    assert view["mode"] == "warm"
    assert view["stale"] is False
    assert view["unchanged_since"] == 40.0
    assert view["hint"].startswith("warm, unchanged since ")
    assert view["scene_description"]["stale"] is False
    assert view["scene_description"]["unchanged_since"] == 40.0
    assert view["scene_description"]["age_s"] == 60.0


def test_an_unchanged_scene_whose_node_stopped_producing_is_stale() -> None:
    view = scene_view(unchanged_scene(100.0, 45_000_000_000, 45.0), now=100.0, stale_after_s=10.0)
    assert view["mode"] == "stale"
    assert view["scene_description"]["stale"] is True
    assert view["scene_description"]["stale_reason"] == "no_recent_result"


def test_the_result_extra_is_read_when_the_message_has_one() -> None:
    from types import SimpleNamespace

    from mcp_perception_buffer.ros_side import result_extra_from_msg

    marked = SimpleNamespace(extra='{"stale": true, "stale_reason": "scene_unchanged"}')
    assert result_extra_from_msg(marked) == {"stale": True, "stale_reason": "scene_unchanged"}
    assert result_extra_from_msg(SimpleNamespace()) == {}  # interfaces without the field
    assert result_extra_from_msg(SimpleNamespace(extra="not json")) == {"raw": "not json"}


def test_a_result_says_who_answered_and_when_the_node_could_not_see() -> None:
    from mcp_perception_buffer.buffer import Result
    from mcp_perception_buffer.views import result_view

    fallback = Result(
        10.0,
        (),
        10.0,
        meta={
            "stale": False,
            "grounder": "owlv2",
            "grounder_fallback": True,
            "fallback_reason": "network",
        },
    )
    view = result_view("find", fallback, 10.5, 5.0)
    assert view["grounder"] == "owlv2"
    assert view["grounder_fallback"] is True
    assert view["fallback_reason"] == "network"

    blind = Result(
        10.0,
        (),
        10.0,
        meta={
            "stale": True,
            "stale_reason": "model_error",
            "cannot_see": True,
            "cannot_see_reason": "quota",
        },
    )
    view = result_view("find", blind, 10.5, 5.0)
    assert view["cannot_see"] is True
    assert view["cannot_see_reason"] == "quota"
    assert view["detections"] == []
