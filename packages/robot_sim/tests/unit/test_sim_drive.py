"""The drive simulation with a hand-stepped clock."""

from __future__ import annotations

import pytest

from robot_mcp_navigation.motion.base import Pose
from robot_sim.config import default_world_path
from robot_sim.drive import DriveSim
from robot_sim.world import load_world


@pytest.fixture
def drive() -> DriveSim:
    return DriveSim(load_world(default_world_path()).map, time_scale=10.0)


def test_the_robot_drives_the_straight_line_at_the_map_speed(drive: DriveSim) -> None:
    reception = drive.map.locations["reception"].pose()
    total = Pose(0, 0).distance_to(reception)
    start = drive.start(reception, now=0.0)
    assert start.driving
    assert start.distance_remaining_m == pytest.approx(total)
    halfway = drive.state(now=total / 0.8 / 10 / 2)
    assert halfway.distance_remaining_m == pytest.approx(total / 2)
    assert halfway.eta_s == pytest.approx(total / 2 / 0.8)
    assert halfway.speed_mps == 0.8
    done = drive.state(now=100.0)
    assert (done.status, done.pose, done.speed_mps) == ("arrived", reception, 0.0)
    assert drive.estimate_s(reception, 100.0) == 0.0


def test_the_closed_door_stops_the_robot_once(drive: DriveSim) -> None:
    mailroom = drive.map.locations["mailroom"].pose()
    drive.start(mailroom, now=0.0)
    failed = drive.state(now=100.0)
    assert failed.status == "failed"
    assert failed.failure is not None
    assert failed.failure.message == "The mailroom door is closed."
    assert failed.pose.distance_to(mailroom) == pytest.approx(0.15 * 17.263, rel=0.01)
    drive.start(mailroom, now=100.0)
    assert drive.state(now=200.0).status == "arrived"


def test_failures_can_be_switched_off() -> None:
    drive = DriveSim(load_world(default_world_path()).map, failures=False)
    drive.start(drive.map.locations["mailroom"].pose(), now=0.0)
    assert drive.state(now=1000.0).status == "arrived"


def test_halt_stops_where_the_robot_is_and_a_new_goal_starts_from_there(drive: DriveSim) -> None:
    kitchen = drive.map.locations["kitchen"].pose()
    drive.start(kitchen, now=0.0)
    halted = drive.halt(now=0.5)
    assert halted.status == "halted"
    assert 0 < halted.pose.distance_to(Pose(0, 0)) < kitchen.distance_to(Pose(0, 0))
    assert drive.state(now=5.0).pose == halted.pose  # stays put
    assert drive.halt(now=6.0).pose == halted.pose  # idempotent
    again = drive.start(kitchen, now=6.0)
    assert again.distance_remaining_m == pytest.approx(halted.pose.distance_to(kitchen))


def test_a_new_goal_replaces_the_running_drive(drive: DriveSim) -> None:
    drive.start(drive.map.locations["meeting_room"].pose(), now=0.0)
    reception = drive.map.locations["reception"].pose()
    drive.start(reception, now=0.2)
    assert drive.state(now=100.0).pose == reception


def test_goals_are_matched_to_map_locations(drive: DriveSim) -> None:
    assert drive.location_at(Pose(17.1, 3.0)) == "mailroom"
    assert drive.location_at(Pose(12.0, 0.0)) is None
    with pytest.raises(ValueError, match="time_scale"):
        DriveSim(drive.map, time_scale=0)
