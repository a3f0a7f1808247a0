import asyncio
import math
from pathlib import Path

import pytest

from robot_mcp_navigation.map import FailureSpec
from robot_mcp_navigation.motion.base import DriveGoal, DriveProgress, MotionBusyError, Pose
from robot_mcp_navigation.motion.simulated import PoseFile, SimulatedBase


class StepClock:
    """A clock the progress callback advances: the simulation is deterministic."""

    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


GOAL = DriveGoal("kitchen", Pose(10.0, 0.0, 1.0))


def make_base(clock: StepClock, failures: list[FailureSpec] | None = None) -> SimulatedBase:
    return SimulatedBase(
        Pose(0.0, 0.0),
        speed_mps=1.0,
        time_scale=2.0,
        failures=failures or [],
        tick_s=0.001,
        clock=clock,
    )


def door(mode: str = "once") -> FailureSpec:
    return FailureSpec.model_validate(
        {
            "location": "kitchen",
            "error_code": "DOOR_CLOSED",
            "message": "closed",
            "suggestions": ["knock"],
            "mode": mode,
            "at_fraction": 0.5,
        }
    )


async def test_drive_reaches_the_goal_with_shrinking_eta_and_time_scaled_elapsed() -> None:
    clock = StepClock()
    base = make_base(clock)
    seen: list[DriveProgress] = []

    async def on_progress(p: DriveProgress) -> None:
        seen.append(p)
        clock.now += 1.0  # one wall second = two simulated seconds = two metres

    result = await base.drive_to(GOAL, on_progress)

    assert result.status == "arrived"
    assert result.pose == GOAL.pose
    assert base.current_pose() == GOAL.pose
    assert [round(p.eta_s) for p in seen] == [10, 8, 6, 4, 2, 0]
    assert result.elapsed_s == pytest.approx(10.0)
    assert seen[-1].pose == GOAL.pose
    assert seen[1].pose.x == pytest.approx(2.0)
    assert seen[1].fraction == pytest.approx(0.2)


async def test_estimate_is_distance_over_speed() -> None:
    base = make_base(StepClock())

    assert base.estimate_duration_s(Pose(3.0, 4.0)) == pytest.approx(5.0)


async def test_a_once_failure_halts_part_way_the_first_time_only() -> None:
    clock = StepClock()
    base = make_base(clock, [door("once")])

    async def on_progress(p: DriveProgress) -> None:
        clock.now += 1.0

    first = await base.drive_to(GOAL, on_progress)
    assert first.status == "failed"
    assert first.failure is not None
    assert first.failure.error_code == "DOOR_CLOSED"
    assert first.failure.suggestions == ["knock"]
    assert base.current_pose().x == pytest.approx(5.0)

    second = await base.drive_to(GOAL, on_progress)
    assert second.status == "arrived"


async def test_an_always_failure_fails_every_drive() -> None:
    clock = StepClock()
    base = make_base(clock, [door("always")])

    async def on_progress(p: DriveProgress) -> None:
        clock.now += 1.0

    assert (await base.drive_to(GOAL, on_progress)).status == "failed"
    await base.stop()
    base_pose = base.current_pose()
    assert (await base.drive_to(DriveGoal("kitchen", GOAL.pose), on_progress)).status == "failed"
    assert base.current_pose().x > base_pose.x


async def test_stop_halts_mid_drive_where_the_robot_is() -> None:
    clock = StepClock()
    base = make_base(clock)
    reports = 0

    async def on_progress(p: DriveProgress) -> None:
        nonlocal reports
        reports += 1
        clock.now += 1.0
        if reports == 2:
            await base.stop()

    result = await base.drive_to(GOAL, on_progress)

    assert result.status == "stopped"
    assert result.pose.x == pytest.approx(4.0)
    assert result.elapsed_s == pytest.approx(4.0)
    assert base.current_pose() == result.pose
    assert not base.driving
    assert math.isclose(result.pose.theta, 0.0)


async def test_a_second_drive_while_driving_is_refused() -> None:
    clock = StepClock()
    base = make_base(clock)
    moving = asyncio.Event()

    async def on_progress(p: DriveProgress) -> None:
        moving.set()

    first = asyncio.create_task(base.drive_to(GOAL, on_progress))
    await asyncio.wait_for(moving.wait(), 5)

    with pytest.raises(MotionBusyError):
        await base.drive_to(GOAL, on_progress)

    await base.stop()
    assert (await asyncio.wait_for(first, 5)).status == "stopped"


def test_non_positive_speed_is_rejected() -> None:
    with pytest.raises(ValueError, match="positive"):
        SimulatedBase(Pose(0, 0), speed_mps=0.0)


async def test_a_coarse_tick_that_jumps_past_the_goal_still_reports_the_arrival() -> None:
    clock = StepClock()
    base = make_base(clock)
    seen: list[DriveProgress] = []

    async def on_progress(p: DriveProgress) -> None:
        seen.append(p)
        clock.now += 60.0  # one tick covers far more than the whole route

    result = await base.drive_to(GOAL, on_progress)

    assert result.status == "arrived"
    assert [p.eta_s for p in seen] == [10.0, 0.0]
    assert seen[-1].distance_remaining_m == 0.0


async def test_the_pose_survives_a_restart_instead_of_teleporting_to_the_start(
    tmp_path: Path,
) -> None:
    """Issue 23 item 7: a restarted base starts where the robot was, not at the dock."""
    clock = StepClock()
    pose_file = PoseFile(tmp_path / "pose.json", "office", min_interval_s=0.0, clock=clock)
    base = SimulatedBase(
        Pose(0.0, 0.0),
        speed_mps=1.0,
        time_scale=2.0,
        tick_s=0.001,
        clock=clock,
        pose_file=pose_file,
    )

    async def on_progress(progress: DriveProgress) -> None:
        clock.now += 1.0  # 2 m per report
        if progress.pose.x >= 4.0:
            raise RuntimeError("killed mid-drive")  # the process dies: no stop, no arrival

    with pytest.raises(RuntimeError):
        await base.drive_to(GOAL, on_progress)

    fresh = PoseFile(tmp_path / "pose.json", "office")
    restarted = SimulatedBase(Pose(0.0, 0.0), speed_mps=1.0, pose_file=fresh)
    assert restarted.current_pose().x == pytest.approx(4.0)
    assert restarted.current_pose().y == pytest.approx(0.0)
    # another map's pose is not used; an unreadable file is reported and ignored
    assert PoseFile(tmp_path / "pose.json", "warehouse").load() is None
    (tmp_path / "bad.json").write_text("{not json")
    assert PoseFile(tmp_path / "bad.json", "office").load() is None


async def test_a_stop_and_an_arrival_are_kept_at_once_and_a_write_failure_never_fails_a_drive(
    tmp_path: Path,
) -> None:
    clock = StepClock()
    path = tmp_path / "pose.json"
    base = SimulatedBase(
        Pose(0.0, 0.0),
        speed_mps=1.0,
        time_scale=2.0,
        tick_s=0.001,
        clock=clock,
        pose_file=PoseFile(path, "office", min_interval_s=3600.0, clock=clock),
    )

    async def advance(progress: DriveProgress) -> None:
        clock.now += 1.0

    result = await base.drive_to(GOAL, advance)
    assert result.status == "arrived"
    assert PoseFile(path, "office").load() == GOAL.pose
    blocked = tmp_path / "file-not-dir"
    blocked.write_text("")
    broken = SimulatedBase(
        Pose(0.0, 0.0),
        speed_mps=1.0,
        time_scale=2.0,
        tick_s=0.001,
        clock=clock,
        pose_file=PoseFile(blocked / "pose.json", "office", clock=clock),
    )
    assert (await broken.drive_to(GOAL, advance)).status == "arrived"
