"""The pose type: distance on the floor and its JSON shape."""

import dataclasses

import pytest

from robot_site_map import Pose


def test_distance_is_on_the_floor_whatever_the_heading() -> None:
    assert Pose(0, 0, 0.0).distance_to(Pose(3, 4, 3.1)) == pytest.approx(5.0)


def test_as_dict_rounds_to_millimetres_and_milliradians() -> None:
    assert Pose(1.23456, -2.0004, 0.12345).as_dict() == {"x": 1.235, "y": -2.0, "theta": 0.123}


def test_heading_defaults_to_zero_and_a_pose_is_immutable() -> None:
    pose = Pose(1.0, 2.0)

    assert pose.theta == 0.0
    with pytest.raises(dataclasses.FrozenInstanceError):
        pose.x = 5.0  # type: ignore[misc]
