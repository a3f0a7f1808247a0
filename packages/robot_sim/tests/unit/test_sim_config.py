"""Settings from the environment and the message conversions."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from robot_sim import messages
from robot_sim.config import ConfigError, default_scenes_dir, load_settings
from robot_sim.store import StoredFrame
from robot_site_map import Pose


def test_defaults_serve_nav2s_names_and_a_five_fps_camera() -> None:
    settings = load_settings({})
    assert settings.action_name == "/navigate_to_pose"
    assert settings.camera_topic == "/camera/image_raw"
    assert (settings.camera_fps, settings.pose_hz, settings.feedback_hz) == (5.0, 20.0, 10.0)
    assert settings.scenes_dir == default_scenes_dir()
    assert settings.world_path.name == "office.yaml"
    assert settings.map_path is None


def test_environment_values_are_read(tmp_path: Path) -> None:
    settings = load_settings(
        {
            "SIM_TIME_SCALE": "10",
            "SIM_SCENES_DIR": str(tmp_path),
            "SIM_MAP": "",
            "LOG_LEVEL": "debug",
        }
    )
    assert settings.time_scale == 10.0
    assert settings.scenes_dir == tmp_path
    assert settings.log_level == "DEBUG"


@pytest.mark.parametrize(
    ("env", "field"),
    [
        ({"SIM_TIME_SCALE": "0"}, "SIM_TIME_SCALE"),
        ({"SIM_POSE_HZ": "5"}, "SIM_POSE_HZ"),
        ({"SIM_SCENES_DIR": "relative/dir"}, "SIM_SCENES_DIR"),
        ({"SIM_ACTION": "navigate_to_pose"}, "SIM_ACTION"),
    ],
)
def test_a_bad_value_is_named(env: dict[str, str], field: str) -> None:
    with pytest.raises(ConfigError, match=field):
        load_settings(env)


def test_poses_convert_both_ways_with_the_yaw_in_the_quaternion() -> None:
    pose = Pose(1.5, -2.0, 1.2)
    back = messages.pose_from_msg(messages.pose_msg(pose))
    assert (back.x, back.y) == (1.5, -2.0)
    assert back.theta == pytest.approx(1.2)
    q = messages.yaw_to_quaternion(math.pi)
    assert messages.quaternion_to_yaw(q) == pytest.approx(math.pi)


def test_messages_carry_their_frames_and_the_image_its_bytes() -> None:
    stamp = messages.seconds_to_duration(0.0)  # any builtin time shape works as a stamp
    amcl = messages.amcl_pose(Pose(1, 2), messages.Time(sec=5))
    assert (amcl.header.frame_id, amcl.header.stamp.sec) == ("map", 5)
    assert amcl.pose.covariance[0] == pytest.approx(0.0025)
    odom = messages.odometry(Pose(1, 2), 0.8, messages.Time(sec=5))
    assert (odom.header.frame_id, odom.child_frame_id, odom.twist.twist.linear.x) == (
        "odom", "base_link", pytest.approx(0.8),
    )  # fmt: skip
    frame = StoredFrame("x", bytes(640 * 480 * 3), 640, 480)
    image = messages.image(frame, messages.Time(sec=5), "camera_optical_frame")
    assert (image.encoding, image.step, image.width, image.height) == ("rgb8", 1920, 640, 480)
    assert len(image.data) == len(frame.data)
    duration = messages.seconds_to_duration(2.5)
    assert (duration.sec, duration.nanosec) == (2, 500_000_000)
    assert (stamp.sec, stamp.nanosec) == (0, 0)


def test_the_map_the_plan_and_the_camera_info_are_nav2s_messages() -> None:
    from robot_sim.floor.grid import Grid

    cells = np.array([[0, 100, -1], [0, 0, 100]], np.int8)
    grid = messages.occupancy_grid(Grid(cells, 0.05, (-2.5, -6.5)), messages.Time(sec=5))
    assert (grid.header.frame_id, grid.info.width, grid.info.height) == ("map", 3, 2)
    assert (grid.info.origin.position.x, grid.info.resolution) == (-2.5, pytest.approx(0.05))
    assert list(grid.data) == [0, 100, -1, 0, 0, 100]
    path = messages.path([(0.0, 0.0), (1.0, 0.0), (1.0, 1.0)], messages.Time(sec=5))
    assert path.header.frame_id == "map"
    assert len(path.poses) == 3
    yaws = [messages.quaternion_to_yaw(p.pose.orientation) for p in path.poses]
    assert yaws == pytest.approx([0.0, math.pi / 2, math.pi / 2])
    assert messages.path([], messages.Time(sec=5)).poses == []
    info = messages.camera_info(640, 480, 400.0, 400.0, 320.0, 240.0, messages.Time(), "cam")
    assert (info.k[0], info.k[2], info.k[5], info.distortion_model) == (
        400.0,
        320.0,
        240.0,
        "plumb_bob",
    )
    depth = messages.depth_image(np.ones((2, 3), np.float32), messages.Time(), "cam")
    assert (depth.encoding, depth.step, len(depth.data)) == ("32FC1", 12, 24)
