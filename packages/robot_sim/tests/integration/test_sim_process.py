"""``robot-sim`` as its own OS process: refuses a bad config with exit 2 and one line; ready
(PID file) with its scenes saved; its camera frames reach a subscriber in another process (over
Fast DDS shared memory, with the local stack's profile); stops cleanly on SIGTERM.

The tests after the first share one robot-sim process started as the local stack starts it
(``deploy/local-stack.yaml``'s environment); the last one stops it."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

from robot_stack_testing import LaunchedProcess, ProcessLauncher, wait_until
from robot_stack_testing.stack import stack_environment

pytestmark = pytest.mark.ros

ROOT = Path(__file__).resolve().parents[4]
STACK_FILE = ROOT / "deploy" / "local-stack.yaml"
FRAME_BYTES = 640 * 480 * 3
COUNTED = 25
"""Frames robot-sim publishes in the counted window (5 s at its 5 fps)."""
MIN_RECEIVED = 0.9
"""Share of them a subscriber must receive. Measured on the loaded 2-core machine (issue 29):
with the local stack's profile 25 of 25 in every run; with Fast DDS's default 512 KB segment
11-18 of 25 in most runs (a frame's fragments do not fit; the reader rarely frees them fast
enough), though a quiet moment can deliver a whole window — the segment test above is the one
that never passes without the profile."""


def test_a_bad_setting_exits_2_with_one_clear_line(tmp_path: Path) -> None:
    done = subprocess.run(
        [sys.executable, "-m", "robot_sim"],
        env={**os.environ, "SIM_WORLD": str(tmp_path / "missing.yaml")},
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert done.returncode == 2
    [line] = [json.loads(x) for x in done.stderr.splitlines() if x.startswith("{")]
    assert line["event"] == "startup_failed"
    assert "world file not found" in line["detail"]
    assert "Traceback" not in done.stderr


@dataclass
class SimProcess:
    process: LaunchedProcess
    scenes: Path


@pytest.fixture(scope="module")
def sim_process(tmp_path_factory: pytest.TempPathFactory) -> Iterator[SimProcess]:
    """robot-sim started with the local stack's environment (its Fast DDS profile), ready."""
    work = tmp_path_factory.mktemp("robot_sim_process")
    ready = work / "robot-sim.pid"
    launcher = ProcessLauncher(work)
    stack_env = stack_environment(
        STACK_FILE, {"python": sys.executable, "root": str(ROOT), "var": str(work)}
    )
    try:
        process = launcher.start(
            "robot_sim",
            [sys.executable, "-m", "robot_sim"],
            env={
                **os.environ,
                **stack_env,
                "SIM_SCENES_DIR": str(work / "scenes"),
                "SIM_READY_FILE": str(ready),
                "SIM_TIME_SCALE": "10",
            },
        )
        wait_until(
            lambda: ready.is_file() and ready.read_text() == str(process.pid), 60.0, "the PID file"
        )
        yield SimProcess(process, work / "scenes")
    finally:
        launcher.stop_all()


def test_the_ready_process_has_saved_its_first_scene(sim_process: SimProcess) -> None:
    saved = {p.name.split("-")[0] for p in sim_process.scenes.glob("*.json")}
    assert saved == {"dock"}  # the first frame, there before the vision node starts


def shared_memory_segments(pid: int) -> dict[str, int]:
    """Fast DDS shared-memory segments a process has mapped (its own and its peers'), by
    size in bytes (ports, the small ``fastdds_port*`` queues, left out)."""
    sizes: dict[str, int] = {}
    for line in Path(f"/proc/{pid}/maps").read_text().splitlines():
        fields = line.split()
        if len(fields) < 6 or not fields[5].startswith("/dev/shm/fastdds_"):
            continue
        if fields[5].startswith("/dev/shm/fastdds_port"):
            continue
        start, end = (int(x, 16) for x in fields[0].split("-"))
        sizes[fields[5]] = sizes.get(fields[5], 0) + end - start
    return sizes


def test_robot_sims_shared_memory_segment_holds_several_camera_frames(
    sim_process: SimProcess,
) -> None:
    """The local stack's Fast DDS profile is in effect: a camera frame's fragments are written
    into the publisher's own segment, and Fast DDS's default one (512 KB) holds not even one.
    This test process runs without a profile (the pytest plugin drops one from the
    environment), so the big segment robot-sim maps is robot-sim's own."""
    wait_until(
        lambda: shared_memory_segments(sim_process.process.pid), 30.0, "robot-sim's segments"
    )
    sizes = shared_memory_segments(sim_process.process.pid)
    assert max(sizes.values()) >= 4 * FRAME_BYTES, sizes


def test_a_subscriber_in_another_process_receives_nearly_every_camera_frame(
    sim_process: SimProcess,
) -> None:
    """Counts, never times: the frames published in a window (their CameraInfo, small, sent with
    each image under the same stamp) against the images received with those stamps."""
    import rclpy
    from rclpy.context import Context
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import CameraInfo, Image

    from robot_sim.node import CAMERA_QOS

    # best effort like the camera; a deeper history than its depth 1 keeps a late spin of this
    # busy process from counting as a lost frame: what is measured is what the transport delivers
    reader_qos = QoSProfile(
        depth=10, history=HistoryPolicy.KEEP_LAST, reliability=ReliabilityPolicy.BEST_EFFORT
    )
    assert reader_qos.reliability == CAMERA_QOS.reliability

    def stamp(msg: Image | CameraInfo) -> tuple[int, int]:
        return (msg.header.stamp.sec, msg.header.stamp.nanosec)

    infos: list[tuple[int, int]] = []
    images: list[tuple[int, int]] = []
    sizes: set[int] = set()

    def on_image(msg: Image) -> None:
        images.append(stamp(msg))
        sizes.add(len(msg.data))

    context = Context()
    rclpy.init(context=context)
    node = rclpy.create_node("camera_frame_counter", context=context)
    node.create_subscription(
        CameraInfo, "/camera/camera_info", lambda m: infos.append(stamp(m)), reader_qos
    )
    node.create_subscription(Image, "/camera/image_raw", on_image, reader_qos)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    spinner = threading.Thread(target=executor.spin, daemon=True)
    spinner.start()
    try:
        wait_until(lambda: len(infos) >= 2 and images, 60.0, "the first camera frames")
        first = len(infos)  # both subscriptions matched: count from here
        wait_until(lambda: len(infos) >= first + COUNTED, 120.0, f"{COUNTED} more frames")
        assert sim_process.process.running()
    finally:
        executor.shutdown(timeout_sec=5.0)
        spinner.join(timeout=5.0)
        node.destroy_node()
        rclpy.try_shutdown(context=context)
    published = set(infos[first : first + COUNTED])
    received = published & set(images)
    assert sizes == {FRAME_BYTES}  # rgb8 640x480, whole
    assert len(received) >= MIN_RECEIVED * len(published), (
        f"{len(received)} of {len(published)} camera frames received"
    )


def test_the_process_stops_cleanly_on_sigterm(sim_process: SimProcess) -> None:
    """Last in this module: it ends the shared process."""
    sim_process.process.popen.send_signal(signal.SIGTERM)
    assert sim_process.process.popen.wait(timeout=30) == 0
    assert "robot_sim_ready" in sim_process.process.log()
