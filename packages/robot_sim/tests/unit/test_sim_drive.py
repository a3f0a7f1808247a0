"""The drive simulation with a hand-stepped clock: straight lines for the motion alone, the
planned path around walls and doors in the office world."""

from __future__ import annotations

import math

import pytest

from robot_sim.config import default_world_path
from robot_sim.costmap import RobotMap
from robot_sim.drive import DriveSim, DriveState
from robot_sim.world import World, load_world
from robot_site_map import Pose, parse_map


@pytest.fixture
def drive() -> DriveSim:
    return DriveSim(load_world(default_world_path()).map, time_scale=10.0)


@pytest.fixture
def world() -> World:
    return load_world(default_world_path())


def office_drive(world: World) -> DriveSim:
    return DriveSim(world.map, 10.0, robot_map=RobotMap(world.floor, world.closed_doors))


def drive_until_stopped(drive: DriveSim, goal: Pose, start: float = 0.0) -> list[DriveState]:
    states = [drive.start(goal, now=start)]
    now = start
    while states[-1].driving and now < start + 60.0:
        now += 0.02  # 0.16 m at 10× and 0.8 m/s
        states.append(drive.state(now))
    return states


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


def test_a_scripted_failure_of_the_map_stops_the_robot_once() -> None:
    nav_map = parse_map(
        {
            "start": "dock",
            "locations": {"dock": {"x": 0, "y": 0}, "mailroom": {"x": 10, "y": 0}},
            "failures": [
                {"location": "mailroom", "error_code": "DOOR_CLOSED", "message": "Closed."}
            ],
        }
    )
    drive = DriveSim(nav_map, time_scale=10.0)
    mailroom = nav_map.locations["mailroom"].pose()
    drive.start(mailroom, now=0.0)
    failed = drive.state(now=100.0)
    assert (failed.status, failed.error_code, failed.error_msg) == ("failed", 208, "Closed.")
    assert failed.pose.distance_to(mailroom) == pytest.approx(1.5)
    drive.start(mailroom, now=100.0)
    assert drive.state(now=200.0).status == "arrived"
    assert DriveSim(nav_map, failures=False).start(mailroom, 0.0).status == "driving"


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


def test_in_the_office_the_robot_follows_the_planned_path_around_the_walls(world: World) -> None:
    drive = office_drive(world)
    kitchen = world.map.locations["kitchen"].pose()
    states = drive_until_stopped(drive, kitchen)
    first = states[0]
    assert first.plan[0] == (0.0, 0.0)
    assert first.plan[-1] == (kitchen.x, kitchen.y)
    assert first.distance_remaining_m > Pose(0, 0).distance_to(kitchen)  # not the straight line
    assert states[-1].status == "arrived"
    assert states[-1].pose == kitchen
    occupied = world.floor.grid.occupied
    for state in states:  # never inside a wall, a door frame or the counter
        row, col = world.floor.grid.cell_of(state.pose.x, state.pose.y)
        assert not occupied[row, col], state.pose
    through_door = [s.pose for s in states if abs(s.pose.y + 1.0) < 0.1]
    assert through_door
    assert all(8.4 < p.x < 9.6 for p in through_door)


def test_the_closed_west_door_is_seen_on_the_way_and_the_robot_goes_round(world: World) -> None:
    drive = office_drive(world)
    mailroom = world.map.locations["mailroom"].pose()
    states = drive_until_stopped(drive, mailroom)
    assert states[0].distance_remaining_m < 20.0  # planned through the hall and the west door
    assert states[-1].status == "arrived"
    assert states[-1].pose == mailroom
    assert states[-1].replans == 1
    assert drive.robot_map is not None
    assert drive.robot_map.known_closed == {"mailroom_west_door"}
    assert max(s.pose.x for s in states) > 19.5  # came in by the east entrance
    seen_at = next(s for s in states if s.replans == 1)
    assert math.dist((seen_at.pose.x, seen_at.pose.y), (14.5, 2.2)) <= 3.6


def test_with_both_mailroom_doors_closed_the_drive_fails_as_nav2_does(world: World) -> None:
    world.set_door("mailroom_east_entrance", True)
    drive = office_drive(world)
    mailroom = world.map.locations["mailroom"].pose()
    states = drive_until_stopped(drive, mailroom)
    failed = states[-1]
    assert (failed.status, failed.error_code) == ("failed", 208)
    assert "no valid path" in failed.error_msg
    assert world.floor.plan.room_at(failed.pose.x, failed.pose.y).label == "the east corridor"
    again = drive.start(mailroom, now=100.0)  # it knows both doors now: no path at once
    assert (again.status, again.error_code) == ("failed", 208)
    assert again.pose == failed.pose


def test_a_door_opened_later_is_believed_closed_until_the_robot_sees_it(world: World) -> None:
    drive = office_drive(world)
    assert drive.robot_map is not None
    mailroom = world.map.locations["mailroom"].pose()
    dock = world.map.locations["dock"].pose()
    drive_until_stopped(drive, mailroom)
    drive_until_stopped(drive, dock, start=100.0)
    world.set_door("mailroom_west_door", False)
    assert drive.robot_map.known_closed == {"mailroom_west_door"}
    far = drive_until_stopped(drive, mailroom, start=200.0)
    assert far[-1].status == "arrived"
    assert max(s.pose.x for s in far) > 19.5
    assert drive.robot_map.known_closed == frozenset()  # seen open from inside the mailroom
    back = drive_until_stopped(drive, dock, start=300.0)
    assert back[-1].status == "arrived"
    assert back[0].distance_remaining_m < 20.0
