"""Entries carry their publisher's GID; retiring a publisher forgets what it published."""

from mcp_perception_buffer.buffer import RollingBuffer
from mcp_perception_buffer.ros_side import publisher_gid

OLD, NEW = b"\x01" * 16, b"\x02" * 16


def test_retiring_a_publisher_forgets_only_its_entries() -> None:
    buffer = RollingBuffer()
    buffer.add_result("find", 1.0, [{"label": "old mug"}], OLD)
    buffer.add_output("find", "found", True, 1.0, OLD)
    buffer.add_result("find", 2.0, [{"label": "new box"}], NEW)
    seq = buffer.seq("find")
    assert buffer.retire("find", {OLD}) == 2
    snap = buffer.snapshot("find")
    assert snap is not None
    assert [r.detections[0]["label"] for r in snap.results] == ["new box"]
    assert "found" not in snap.outputs
    assert snap.seq > seq


def test_a_buffer_left_empty_by_retiring_is_dropped() -> None:
    buffer = RollingBuffer()
    buffer.add_output("find", "found", True, 1.0, OLD)
    assert buffer.retire("find", {OLD}) == 1
    assert buffer.snapshot("find") is None
    assert buffer.skills() == []


def test_retiring_nothing_or_an_unknown_skill_changes_nothing() -> None:
    buffer = RollingBuffer()
    buffer.add_result("find", 1.0, [], NEW)
    assert buffer.retire("find", set()) == 0
    assert buffer.retire("other", {OLD}) == 0
    assert buffer.retire("find", {OLD}) == 0
    assert buffer.seq("find") == 1


def test_the_publisher_gid_is_read_from_rclpy_message_info() -> None:
    info = {"publisher_gid": {"implementation_identifier": "rmw_fastrtps_cpp", "data": OLD}}
    assert publisher_gid(info) == OLD
    assert publisher_gid({"publisher_gid": {"data": list(NEW)}}) == NEW
    assert publisher_gid({"publisher_gid": None}) is None
    assert publisher_gid(None) is None
