"""Frame sources: folder (EXIF, downscale, corrupt files), VideoCapture reconnects, ROS topic."""

from __future__ import annotations

import threading
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from PIL import Image as PILImage

from robot_mcp_perception.frames import (
    FolderFrameSource,
    Frame,
    FrameSourceError,
    downscale,
    load_image,
)
from robot_mcp_perception.frames_capture import VideoCaptureFrameSource
from robot_stack_testing import wait_until


def _write(
    path: Path, width: int = 64, height: int = 32, colour: tuple[int, int, int] = (200, 10, 10)
) -> Path:
    PILImage.new("RGB", (width, height), colour).save(path)
    return path


def test_exif_orientation_is_applied(tmp_path: Path) -> None:
    image = PILImage.new("RGB", (60, 20), (0, 0, 255))
    exif = PILImage.Exif()
    exif[0x0112] = 6  # rotate 90° clockwise on display
    path = tmp_path / "rotated.jpg"
    image.save(path, exif=exif)

    loaded = load_image(path, max_side=0)

    assert loaded.shape == (60, 20, 3)


def test_downscale_keeps_aspect_and_never_upscales() -> None:
    big = np.zeros((480, 640, 3), dtype=np.uint8)

    assert downscale(big, 320).shape == (240, 320, 3)
    assert downscale(big, 1280) is big


def test_folder_source_loops_and_skips_a_corrupt_file_with_a_warning(
    tmp_path: Path, log_events: list[dict[str, Any]]
) -> None:
    _write(tmp_path / "a.png", colour=(255, 0, 0))
    (tmp_path / "b.png").write_bytes(b"\x89PNG\r\n\x1a\n not really a png")
    _write(tmp_path / "c.png", colour=(0, 255, 0))
    frames: list[Frame] = []
    source = FolderFrameSource(str(tmp_path), fps=100.0, max_side=32)

    source.start(None, on_frame=frames.append)
    try:
        wait_until(lambda: len(frames) >= 5, 10.0, "five frames")
    finally:
        source.stop()

    assert [tuple(f.image[0, 0]) for f in frames[:3]] == [(255, 0, 0), (0, 255, 0), (255, 0, 0)]
    assert frames[0].image.shape == (16, 32, 3)
    assert [f.seq for f in frames[:3]] == [1, 2, 3]
    assert source.latest() is not None
    assert any(e["event"] == "frame_skipped" and e["path"].endswith("b.png") for e in log_events)
    assert source.skipped[0].name == "b.png"


def test_missing_folder_fails_with_a_message_that_says_how_to_generate_it(tmp_path: Path) -> None:
    source = FolderFrameSource(str(tmp_path / "nope"))

    with pytest.raises(FrameSourceError, match="sample_scenes"):
        source.check()


def test_empty_folder_is_refused(tmp_path: Path) -> None:
    with pytest.raises(FrameSourceError, match="no images"):
        FolderFrameSource(str(tmp_path)).check()


class FlakyCapture:
    """Delivers ``frames`` frames, then fails (a dropped stream)."""

    def __init__(self, opened: bool, frames: int) -> None:
        self.opened = opened
        self.frames = frames
        self.released = False

    def isOpened(self) -> bool:
        return self.opened

    def read(self) -> tuple[bool, Any]:
        if self.frames <= 0:
            return False, None
        self.frames -= 1
        bgr = np.zeros((8, 8, 3), dtype=np.uint8)
        bgr[:, :, 0] = 255  # blue in BGR
        return True, bgr

    def release(self) -> None:
        self.released = True


def test_capture_source_reconnects_with_backoff_after_failures(
    log_events: list[dict[str, Any]],
) -> None:
    attempts: list[FlakyCapture] = []
    script = [(False, 0), (False, 0), (True, 3), (True, 100_000)]

    def open_capture() -> FlakyCapture:
        opened, frames = script[min(len(attempts), len(script) - 1)]
        attempts.append(FlakyCapture(opened, frames))
        return attempts[-1]

    got: list[Frame] = []
    source = VideoCaptureFrameSource(
        open_capture, label="fake", reconnect_initial_s=0.01, reconnect_max_s=0.04
    )
    source.start(None, on_frame=got.append)
    try:
        wait_until(lambda: len(attempts) >= 4 and len(got) >= 5, 10.0, "reconnect and frames")
    finally:
        source.stop()

    backoffs = [e["backoff_s"] for e in log_events if e["event"] == "frame_source_reconnect"]
    assert backoffs[:3] == [0.01, 0.02, 0.01]  # reset after a good connection
    assert source.reconnects >= 3
    assert tuple(got[0].image[0, 0]) == (0, 0, 255)  # BGR → RGB


@pytest.mark.ros
def test_ros_source_takes_stamp_and_frame_id_from_the_camera_header() -> None:
    import rclpy
    from rclpy.context import Context
    from rclpy.executors import SingleThreadedExecutor
    from sensor_msgs.msg import Image as ImageMsg
    from std_msgs.msg import Header

    from robot_mcp_perception.conversions import ns_to_stamp, rgb_to_image_msg
    from robot_mcp_perception.frames_ros import CAMERA_QOS, RosFrameSource

    context = Context()
    rclpy.init(context=context)
    node = rclpy.create_node("camera_test", context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    stop = threading.Event()
    thread = threading.Thread(
        target=lambda: [executor.spin_once(0.05) for _ in iter(stop.is_set, True)]
    )
    thread.start()
    source = RosFrameSource("/cam/image_raw", max_side=1280)
    frames: list[Frame] = []
    try:
        source.start(node, on_frame=frames.append)
        publisher = node.create_publisher(ImageMsg, "/cam/image_raw", CAMERA_QOS)
        image = np.zeros((4, 6, 3), dtype=np.uint8)
        msg = rgb_to_image_msg(image, Header(stamp=ns_to_stamp(5_000_000_007), frame_id="cam"))
        bad = ImageMsg(encoding="yuv422", height=1, width=1, step=2, data=b"\x00\x00")

        def publish_bad_until_rejected() -> bool:
            publisher.publish(bad)
            return source.rejected > 0

        def publish_until_received() -> bool:
            publisher.publish(msg)
            return bool(frames)

        wait_until(publish_bad_until_rejected, 10.0, "a rejected frame", interval_s=0.1)

        wait_until(publish_until_received, 10.0, "a camera frame", interval_s=0.1)
    finally:
        source.stop()
        stop.set()
        thread.join(timeout=5.0)
        executor.shutdown()
        node.destroy_node()
        rclpy.shutdown(context=context)

    assert frames[0].stamp_ns == 5_000_000_007
    assert frames[0].frame_id == "cam"
    assert frames[0].image.shape == (4, 6, 3)
    assert source.rejected >= 1
