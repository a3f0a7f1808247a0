"""The ROS peers' payloads are deterministic (the cross-process tests compare digests)."""

from __future__ import annotations

import sys

import pytest

from robot_stack_testing import ProcessLauncher, ros_peers, wait_until


def test_sample_mask_is_deterministic_mono8_full_frame() -> None:
    mask = ros_peers.sample_mask()
    assert len(mask) == ros_peers.MASK_WIDTH * ros_peers.MASK_HEIGHT
    assert set(mask) == {0, 255}
    assert ros_peers.mask_digest(mask) == ros_peers.mask_digest(ros_peers.sample_mask())


@pytest.mark.ros
def test_detection_array_carries_the_mask_stamp_and_frame() -> None:
    array = ros_peers.build_detection_array("segment_all")
    assert array.skill == "segment_all"
    assert array.header.frame_id == ros_peers.FRAME_ID
    assert bytes(array.detections[0].mask.data) == ros_peers.sample_mask()


def test_cli_rejects_unknown_commands() -> None:
    with pytest.raises(SystemExit):
        ros_peers.main(["dance"])


@pytest.mark.ros
@pytest.mark.parametrize("command", ["publish-mask", "serve-echo"])
def test_peers_run_and_exit_by_themselves(command: str, launcher: ProcessLauncher) -> None:
    process = launcher.start(
        command,
        [sys.executable, "-m", "robot_stack_testing.ros_peers", command, "--seconds", "0.5"],
    )
    wait_until(lambda: not process.running(), 20.0, f"{command} to exit")
    assert process.popen.returncode == 0, process.log()
