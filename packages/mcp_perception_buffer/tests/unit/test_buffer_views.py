import json

from mcp_perception_buffer.buffer import RollingBuffer
from mcp_perception_buffer.views import detection_view, scene_view

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
    assert view["reason"] == "over_budget"
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
