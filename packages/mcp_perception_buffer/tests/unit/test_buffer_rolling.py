import threading

import pytest

from mcp_perception_buffer.buffer import OutputValue, Result, RollingBuffer
from mcp_perception_buffer.discovery import skills_in_graph


class Clock:
    def __init__(self) -> None:
        self.now = 1000.0

    def __call__(self) -> float:
        return self.now


def test_each_stream_keeps_at_most_max_count_entries() -> None:
    buffer = RollingBuffer(max_count=3)
    for i in range(5):
        buffer.add_result("cup", float(i), [{"label": f"c{i}"}])
        buffer.add_output("cup", "found", i, float(i))
    snap = buffer.snapshot("cup")
    assert snap is not None
    assert [r.stamp for r in snap.results] == [2.0, 3.0, 4.0]
    assert [v.value for v in snap.outputs["found"]] == [2, 3, 4]
    assert snap.seq == 10


def test_entries_older_than_max_age_are_pruned_on_read_and_write() -> None:
    clock = Clock()
    buffer = RollingBuffer(max_count=10, max_age_s=5.0, clock=clock)
    buffer.add_result("cup", 1.0, [])
    buffer.add_output("cup", "found", True, 1.0)
    clock.now += 6
    snap = buffer.snapshot("cup")
    assert snap is not None
    assert list(snap.results) == []
    assert list(snap.outputs["found"]) == []
    buffer.add_result("cup", 2.0, [])
    assert [r.stamp for r in buffer.snapshot("cup").results] == [2.0]  # type: ignore[union-attr]


def test_a_snapshot_is_a_copy_that_later_writes_do_not_change() -> None:
    buffer = RollingBuffer()
    buffer.add_result("cup", 1.0, [])
    snap = buffer.snapshot("cup")
    buffer.add_result("cup", 2.0, [])
    assert snap is not None
    assert len(snap.results) == 1
    assert snap.last_stamp() == 1.0


def test_dropping_a_skill_forgets_it() -> None:
    buffer = RollingBuffer()
    buffer.add_output("door", "open", False, 3.0)
    assert buffer.skills() == ["door"]
    assert buffer.latest_output("door", "open") == buffer.snapshot("door").outputs["open"][-1]  # type: ignore[union-attr]
    assert buffer.drop("door") is True
    assert buffer.drop("door") is False
    assert buffer.snapshot("door") is None
    assert buffer.latest_output("door", "open") is None
    assert buffer.seq("door") == 0


def test_listeners_see_every_write() -> None:
    buffer = RollingBuffer()
    seen: list[tuple[str, Result | OutputValue]] = []
    buffer.add_listener(lambda skill, item: seen.append((skill, item)))
    buffer.add_result("a", 1.0, [])
    buffer.add_output("b", "x", 1, 2.0)
    assert [(s, type(i).__name__) for s, i in seen] == [("a", "Result"), ("b", "OutputValue")]


def test_concurrent_writers_from_threads_lose_nothing_within_the_bound() -> None:
    buffer = RollingBuffer(max_count=10_000)

    def write(skill: str) -> None:
        for i in range(500):
            buffer.add_result(skill, float(i), [])

    threads = [threading.Thread(target=write, args=(f"s{n % 2}",)) for n in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout=30)
    assert buffer.seq("s0") == 1000
    assert buffer.seq("s1") == 1000


def test_bad_bounds_are_refused() -> None:
    with pytest.raises(ValueError):
        RollingBuffer(max_count=0)
    with pytest.raises(ValueError):
        RollingBuffer(max_age_s=0)


def test_discovery_groups_meta_and_output_topics_per_skill_and_ignores_the_rest() -> None:
    meta = "ros2_vision_interfaces/msg/VisionDetectionArray"
    out = "ros2_vision_interfaces/msg/StampedString"
    graph = {
        "/vision/cup/detections": [meta],
        "/vision/cup/detections_meta": [meta],
        "/vision/cup/found": [out],
        "/vision/cup/overlay": ["sensor_msgs/msg/Image"],
        "/vision/scene/scene_description": [out],
        "/vision/stats": [out],
        "/vision/a/b/c": [out],
        "/camera/image_raw": ["sensor_msgs/msg/Image"],
        "/vision/odd/thing": ["std_msgs/msg/String"],
    }
    skills = skills_in_graph(graph)
    assert set(skills) == {"cup", "scene"}
    assert skills["cup"].meta == "/vision/cup/detections_meta"
    assert dict(skills["cup"].outputs) == {"found": "/vision/cup/found"}
    assert skills["cup"].all() == ["/vision/cup/detections_meta", "/vision/cup/found"]
    assert skills["scene"].meta is None
    assert skills["scene"].all() == ["/vision/scene/scene_description"]
