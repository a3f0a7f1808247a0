"""MCAP recording: read back by an independent reader (rosbags), rotation, repair after a
crash, forgetting from recordings, retention and the size cap."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path
from typing import Any

import pytest
import yaml
from rclpy.serialization import serialize_message
from rosbags.highlevel import AnyReader

from robot_mcp_episodic.bags import BagRecorder
from robot_mcp_episodic.recording_filter import sighting_selector
from robot_mcp_episodic.retention import Janitor
from robot_mcp_episodic.store.base import EpisodicStore, Note

META = "ros2_vision_interfaces/msg/VisionDetectionArray"
POSE = "geometry_msgs/msg/PoseWithCovarianceStamped"
T = 1_790_000_000


def detections(stamp: int, *labels: str) -> Any:
    from ros2_vision_interfaces.msg import VisionDetection, VisionDetectionArray

    msg = VisionDetectionArray()
    msg.header.stamp.sec = stamp
    msg.header.frame_id = "camera"
    msg.skill = "detect"
    for label in labels:
        det = VisionDetection()
        det.label = label
        det.score = 0.75
        det.box.x_offset = 12
        det.box.width = 30
        msg.detections.append(det)
    return msg


def pose(stamp: int, x: float) -> Any:
    from geometry_msgs.msg import PoseWithCovarianceStamped

    msg = PoseWithCovarianceStamped()
    msg.header.stamp.sec = stamp
    msg.header.frame_id = "map"
    msg.pose.pose.position.x = x
    msg.pose.pose.orientation.w = 1.0
    return msg


def read_bags(root: Path) -> list[tuple[str, int, Any]]:
    """Every message of every bag under ``root``, read with rosbags (not our code)."""
    found = []
    for bag in sorted((root / "bags").iterdir()):
        with AnyReader([bag]) as reader:
            for connection, stamp, raw in reader.messages():
                found.append((connection.topic, stamp, reader.deserialize(raw, connection.msgtype)))
    return found


def test_messages_read_back_by_rosbags_equal_what_was_recorded(tmp_path: Path) -> None:
    recorder = BagRecorder(tmp_path)
    for i in range(5):
        frame = serialize_message(detections(T + i, "mug", f"thing{i}"))
        recorder.write("/vision/detect/detections_meta", META, frame, (T + i) * 10**9)
        recorder.write(
            "/amcl_pose", POSE, serialize_message(pose(T + i, float(i))), (T + i) * 10**9
        )
    recorder.close()

    read = read_bags(tmp_path)
    metas = [m for topic, _, m in read if topic == "/vision/detect/detections_meta"]
    poses = [m for topic, _, m in read if topic == "/amcl_pose"]
    assert [[d.label for d in m.detections] for m in metas] == [
        ["mug", f"thing{i}"] for i in range(5)
    ]
    assert [m.detections[0].box.x_offset for m in metas] == [12] * 5
    assert [m.header.stamp.sec for m in metas] == [T + i for i in range(5)]
    assert [m.pose.pose.position.x for m in poses] == [0.0, 1.0, 2.0, 3.0, 4.0]
    [bag] = (tmp_path / "bags").iterdir()
    info = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert info["storage_identifier"] == "mcap"
    assert info["message_count"] == 10
    assert info["starting_time"]["nanoseconds_since_epoch"] == T * 10**9
    assert info["duration"]["nanoseconds"] == 4 * 10**9
    assert {t["topic_metadata"]["name"]: t["message_count"]
            for t in info["topics_with_message_count"]} == {
        "/amcl_pose": 5, "/vision/detect/detections_meta": 5,
    }  # fmt: skip


def test_bags_rotate_by_time(tmp_path: Path) -> None:
    recorder = BagRecorder(tmp_path, rotate_s=60)
    for i in range(0, 200, 20):
        recorder.write("/amcl_pose", POSE, serialize_message(pose(T + i, 1.0)), (T + i) * 10**9)
    recorder.close()
    bags = recorder.bags()
    assert [b.messages for b in bags] == [3, 3, 3, 1]
    assert all(not b.open for b in bags)
    assert len(read_bags(tmp_path)) == 10


def test_the_open_bag_says_how_many_messages_a_crash_would_keep(tmp_path: Path) -> None:
    recorder = BagRecorder(tmp_path)
    for i in range(3):
        recorder.write("/amcl_pose", POSE, serialize_message(pose(T + i, 1.0)), (T + i) * 10**9)
    (bag,) = recorder.bags()
    assert (bag.open, bag.messages, bag.on_disk) == (True, 3, 0)
    recorder.flush()
    recorder.write("/amcl_pose", POSE, serialize_message(pose(T + 3, 1.0)), (T + 3) * 10**9)
    (bag,) = recorder.bags()
    assert (bag.messages, bag.on_disk) == (4, 3)
    recorder.close()
    (bag,) = recorder.bags()
    assert (bag.open, bag.messages, bag.on_disk) == (False, 4, 4)


def test_a_bag_cut_short_by_kill_9_is_repaired_with_every_flushed_message(
    tmp_path: Path,
) -> None:
    script = textwrap.dedent(f"""
        import os, signal
        from pathlib import Path
        from rclpy.serialization import serialize_message
        from geometry_msgs.msg import PoseWithCovarianceStamped
        from robot_mcp_episodic.bags import BagRecorder
        recorder = BagRecorder(Path({str(tmp_path)!r}))
        for i in range(30):
            msg = PoseWithCovarianceStamped()
            msg.header.stamp.sec = {T} + i
            msg.pose.pose.position.x = float(i)
            recorder.write("/amcl_pose", {POSE!r}, serialize_message(msg), ({T} + i) * 10**9)
            if i == 19:
                recorder.flush()
        os.kill(os.getpid(), signal.SIGKILL)
    """)
    done = subprocess.run([sys.executable, "-c", script], timeout=60, check=False)
    assert done.returncode == -9
    [bag] = (tmp_path / "bags").iterdir()
    assert not (bag / "metadata.yaml").exists()

    recorder = BagRecorder(tmp_path)  # the restart
    assert recorder.repaired == [bag]
    xs = [m.pose.pose.position.x for _, _, m in read_bags(tmp_path)]
    assert xs[:20] == [float(i) for i in range(20)]  # everything flushed survives
    recorder.close()


def test_forget_rewrites_the_bags_without_the_chosen_messages(tmp_path: Path) -> None:
    recorder = BagRecorder(tmp_path)
    for i in range(10):
        labels = ("toothbrush", "mug") if 3 <= i <= 5 else ("mug",)
        recorder.write("/vision/detect/detections_meta", META,
                       serialize_message(detections(T + i, *labels)), (T + i) * 10**9)  # fmt: skip
    selector = sighting_selector([("detect", "toothbrush", T + 3.0, T + 5.0)])

    assert recorder.forget(T, T + 10, selector, dry_run=True) == 3  # the open bag, counted
    assert len(read_bags_open_safe(recorder, tmp_path)) == 10
    assert recorder.forget(T, T + 10, selector, dry_run=False) == 3

    read = read_bags(tmp_path)
    assert len(read) == 7
    assert all(d.label != "toothbrush" for _, _, m in read for d in m.detections)
    recorder.write("/amcl_pose", POSE, serialize_message(pose(T + 20, 1.0)), (T + 20) * 10**9)
    recorder.close()  # recording continues in a new bag
    assert len(read_bags(tmp_path)) == 8


def read_bags_open_safe(recorder: BagRecorder, root: Path) -> list[tuple[str, int, Any]]:
    recorder.close()
    return read_bags(root)


def test_retention_and_the_size_cap_delete_the_oldest_bags_first(
    tmp_path: Path, sqlite_store: EpisodicStore
) -> None:
    recorder = BagRecorder(tmp_path, rotate_s=3600)
    blob = os.urandom(200_000)  # incompressible, so sizes are predictable
    for hour in range(4):
        msg = detections(T + hour * 3600, "mug")
        msg.extra = blob.hex()
        recorder.write("/vision/detect/detections_meta", META, serialize_message(msg),
                       (T + hour * 3600) * 10**9)  # fmt: skip
    recorder.close()
    sqlite_store.save_notes([Note("n-old", "robot-1", "office", T - 100 * 86400, "scene", "old")])
    now = T + 4 * 3600.0

    janitor = Janitor(sqlite_store, recorder, bags_h=3.5, index_d=90, max_mb=10_000,
                      clock=lambda: now)  # fmt: skip
    done = janitor.enforce()
    assert done.bags_deleted == 1  # the bag of hour 0 ended 4 h ago
    assert done.rows_deleted["notes"] == 1  # older than 90 days
    assert len(recorder.bags()) == 3

    index_bytes = sqlite_store.stats().size_bytes
    cap_mb = (index_bytes + recorder.bags()[-1].size_bytes + 1000) / (1024 * 1024)
    capped = Janitor(sqlite_store, recorder, bags_h=1000, index_d=90, max_mb=cap_mb,
                     clock=lambda: now)  # fmt: skip
    assert capped.enforce().bags_deleted == 2
    [kept] = recorder.bags()
    assert kept.start == T + 3 * 3600
    assert capped.size_bytes() <= cap_mb * 1024 * 1024


def test_the_size_cap_trims_the_oldest_index_rows_when_no_bag_is_left(
    tmp_path: Path, sqlite_store: EpisodicStore
) -> None:
    notes = [
        Note(f"n-{i}", "robot-1", "office", T + i * 60.0, "scene", "x" * 2000) for i in range(600)
    ]
    sqlite_store.save_notes(notes)
    before = sqlite_store.stats().size_bytes
    janitor = Janitor(sqlite_store, None, bags_h=1, index_d=90,
                      max_mb=before / 2 / (1024 * 1024), clock=lambda: T + 36_000)  # fmt: skip
    done = janitor.enforce()
    assert done.rows_deleted["notes"] > 0
    assert sqlite_store.stats().size_bytes <= before / 2
    oldest = sqlite_store.stats().kinds["notes"].oldest
    assert oldest is not None
    assert oldest > T


@pytest.mark.parametrize("rotate_s", [3600.0])
def test_a_bag_gets_a_new_name_when_one_exists(tmp_path: Path, rotate_s: float) -> None:
    for _ in range(2):
        recorder = BagRecorder(tmp_path, rotate_s)
        recorder.write("/amcl_pose", POSE, serialize_message(pose(T, 1.0)), T * 10**9)
        recorder.close()
    assert len(recorder.bags()) == 2
