"""robot-sim honours the supervisor lock as a robot's twist_mux does (issue 27): never heard,
``true`` or silent longer than the timeout = the base halts; the goal stays, as with Nav2, and
drives on when the lock opens, or ends ABORTED with FAILED_TO_MAKE_PROGRESS (105) once the
progress allowance (SIM_PROGRESS_TIMEOUT_S, here 1.5 s) ran out."""

from __future__ import annotations

import math
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from std_msgs.msg import Bool

from robot_ros_bridge.lock_publisher import LOCK_QOS
from robot_sim.config import SimSettings, default_world_path
from robot_sim.nav2_server import FAILED_TO_MAKE_PROGRESS
from robot_stack_testing import wait_until

from .conftest import Received, Sim

pytestmark = pytest.mark.ros
LOCK = "/robot/supervisor_lock"
ARM_LOCK = "/robot/supervisor_lock/manipulation"


@pytest.fixture
def settings(tmp_path: Path) -> SimSettings:
    return SimSettings(
        SIM_WORLD=default_world_path(),
        SIM_SCENES_DIR=tmp_path / "scenes",
        SIM_TIME_SCALE=5.0,
        SIM_SUPERVISOR_LOCK=True,
        SIM_PROGRESS_TIMEOUT_S=1.5,
    )


class LockTopic:
    """The motion server's side: ``value`` at 20 Hz on the lock topic until ``silence()``."""

    def __init__(self, sim: Sim) -> None:
        self.value = False
        self._node = sim.client
        self._publisher = sim.client.create_publisher(Bool, LOCK, LOCK_QOS)
        self._timer: Any = sim.client.create_timer(0.05, self._tick)

    def _tick(self) -> None:
        self._publisher.publish(Bool(data=self.value))

    def silence(self) -> None:
        self._node.destroy_timer(self._timer)


@pytest.fixture
def lock(sim: Sim) -> Iterator[LockTopic]:
    topic = LockTopic(sim)
    yield topic
    topic.silence()


def position(amcl: Received) -> tuple[float, float]:
    msg = amcl.last()
    return (msg.pose.pose.position.x, msg.pose.pose.position.y)


def still_since(amcl: Received, seconds: float) -> bool:
    """The last ``seconds`` of /amcl_pose all show the same position (and there were some)."""
    recent = amcl.since(time.monotonic() - seconds)
    points = {(round(m.pose.pose.position.x, 4), round(m.pose.pose.position.y, 4)) for m in recent}
    return len(recent) >= 3 and len(points) == 1


def drive_towards_kitchen(sim: Sim) -> Any:
    kitchen = sim.node.camera.world.map.locations["kitchen"]
    handle = sim.send_goal(kitchen.x, kitchen.y)
    assert handle.accepted
    return handle


def test_a_lock_never_heard_holds_the_base_and_the_goal_ends_failed_to_make_progress(
    sim: Sim,
) -> None:
    wait_until(lambda: sim.amcl.last() is not None, 10, "a pose")
    start = position(sim.amcl)

    result = sim.result(drive_towards_kitchen(sim))

    assert result.result.error_code == FAILED_TO_MAKE_PROGRESS
    assert "held by its lock" in result.result.error_msg
    assert position(sim.amcl) == start


def test_true_halts_a_drive_at_once_and_the_pose_stops_changing(sim: Sim, lock: LockTopic) -> None:
    wait_until(lambda: not sim.node.lock.locked(), 10, "the lock open")
    handle = drive_towards_kitchen(sim)
    wait_until(lambda: sim.node.drive.state(time.monotonic()).driving, 10, "driving")
    wait_until(lambda: not still_since(sim.amcl, 0.3), 10, "the pose moving")

    lock.value = True
    result = sim.result(handle)

    assert result.result.error_code == FAILED_TO_MAKE_PROGRESS
    wait_until(lambda: still_since(sim.amcl, 0.5), 10, "the pose still")
    assert not sim.node.drive.state(time.monotonic()).driving


def test_a_silent_lock_publisher_halts_the_drive_after_the_timeout(
    sim: Sim, lock: LockTopic
) -> None:
    wait_until(lambda: not sim.node.lock.locked(), 10, "the lock open")
    handle = drive_towards_kitchen(sim)
    wait_until(lambda: not still_since(sim.amcl, 0.3), 10, "the pose moving")
    before = position(sim.amcl)

    lock.silence()  # the motion server died
    result = sim.result(handle)

    assert result.result.error_code == FAILED_TO_MAKE_PROGRESS
    halted = position(sim.amcl)
    assert math.dist(before, halted) > 0  # it drove until the timeout ran out, then stopped
    wait_until(lambda: still_since(sim.amcl, 0.5), 10, "the pose still")


def test_the_arm_obeys_its_own_servers_lock_over_ros_and_the_base_its_own(
    sim: Sim, lock: LockTopic
) -> None:
    """Issue 39: with the base's lock open the arm is still held until the manipulation
    server's lock (never heard here) says otherwise; the arm gives up as the base does."""
    assert sim.node.lock is not None
    assert sim.node.arm_lock is not None
    wait_until(lambda: not sim.node.lock.locked(), 10, "the base's lock open")
    assert sim.node.manipulation.held == sim.node.arm_lock.locked
    assert sim.node.arm_lock.held_by() == [ARM_LOCK]  # never heard: locked
    arm = sim.client.create_publisher(Bool, ARM_LOCK, LOCK_QOS)
    timer = sim.client.create_timer(0.05, lambda: arm.publish(Bool(data=False)))
    wait_until(lambda: not sim.node.manipulation.held(), 10, "the arm's lock open")

    sim.client.destroy_timer(timer)  # the arm's server died

    wait_until(sim.node.manipulation.held, 10, "the arm held by its silent lock")
    assert not sim.node.lock.locked()  # the base's lock stays open: its wheels may turn
    assert sim.node.manipulation.held_timeout_s == 1.5  # SIM_PROGRESS_TIMEOUT_S, as the base
