"""The lock gate dates a halt as twist_mux would, not by when a starved robot-sim gets to it;
the arm and the base each obey their own server's lock (issue 39)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import pytest

from robot_sim.config import (
    ARM_LOCK_TOPIC,
    BASE_LOCK_TOPIC,
    ConfigError,
    SimSettings,
    load_settings,
)
from robot_sim.drive import DriveSim
from robot_sim.supervisor_lock import ArmLockGate, SupervisorLockGate
from robot_sim.world import load_world


class FakeNode:
    """Records the gate's subscriptions and timers (no ROS)."""

    def __init__(self) -> None:
        self.subscriptions: dict[str, Callable[[Any], None]] = {}

    def create_subscription(
        self, _type: Any, topic: str, callback: Any, *_: Any, **__: Any
    ) -> None:
        self.subscriptions[topic] = callback

    def create_timer(self, *_: Any, **__: Any) -> None:
        return None


class Msg:
    def __init__(self, data: bool) -> None:
        self.data = data


def published(node: FakeNode, clock: dict[str, float], until: float) -> None:
    """The motion server's lock, open, at 10 Hz up to ``until``."""
    for tick in range(1, round(until * 10) + 1):
        clock["now"] = tick / 10
        node.subscriptions["/lock"](Msg(False))


@pytest.fixture
def drive(settings: SimSettings) -> DriveSim:
    return DriveSim(load_world(settings.world_path, settings.map_path).map, 1.0)


def test_a_silent_lock_halts_the_drive_where_it_was_when_the_timeout_ran_out(
    drive: DriveSim,
) -> None:
    clock = {"now": 0.0}
    node = FakeNode()
    gate = SupervisorLockGate(node, drive, ["/lock"], 0.5, lambda: clock["now"])  # type: ignore[arg-type]
    kitchen = drive.map.locations["kitchen"].pose()
    node.subscriptions["/lock"](Msg(False))
    drive.start(kitchen, 0.0)
    published(node, clock, until=0.9)  # the motion server's last word at 0.9
    gate.enforce()

    clock["now"] = 3.0  # robot-sim starved for 2 s; the lock ran out at 1.4
    gate.enforce()

    state = drive.state(3.0)
    assert state.status == "halted"
    start = drive.map.locations[drive.map.start].pose()
    assert state.pose.distance_to(start) == pytest.approx(drive.speed * 1.4, abs=0.01)


def test_a_lock_message_queued_through_a_stall_does_not_hide_that_the_lock_ran_out(
    drive: DriveSim,
) -> None:
    clock = {"now": 0.0}
    node = FakeNode()
    gate = SupervisorLockGate(node, drive, ["/lock"], 0.5, lambda: clock["now"])  # type: ignore[arg-type]
    node.subscriptions["/lock"](Msg(False))
    drive.start(drive.map.locations["kitchen"].pose(), 0.0)
    published(node, clock, until=0.9)
    gate.enforce()

    clock["now"] = 3.0  # robot-sim starved for 2 s; the queued message is handled first
    node.subscriptions["/lock"](Msg(False))
    gate.enforce()

    state = drive.state(3.0)
    assert state.status == "halted"  # the wheels did not turn on while twist_mux held them
    start = drive.map.locations[drive.map.start].pose()
    assert state.pose.distance_to(start) == pytest.approx(drive.speed * 1.4, abs=0.01)
    assert not gate.locked()  # and the lock is open again: the goal may drive on


def test_true_halts_at_once_and_false_again_lets_a_new_drive_go(drive: DriveSim) -> None:
    clock = {"now": 0.0}
    node = FakeNode()
    gate = SupervisorLockGate(node, drive, ["/lock"], 0.5, lambda: clock["now"])  # type: ignore[arg-type]
    node.subscriptions["/lock"](Msg(False))
    drive.start(drive.map.locations["kitchen"].pose(), 0.0)
    clock["now"] = 0.2

    node.subscriptions["/lock"](Msg(True))

    assert drive.state(0.2).status == "halted"
    assert gate.locked()
    node.subscriptions["/lock"](Msg(False))
    assert not gate.locked()


def test_the_arm_has_its_own_lock_a_dead_arm_server_stops_the_arm_and_not_the_base(
    drive: DriveSim,
) -> None:
    """Issue 39: the arm's controller sits behind the manipulation server's lock, the base behind
    navigation's. A killed arm server (its lock silent) stops the arm; the base drives on."""
    clock = {"now": 0.0}
    node = FakeNode()
    base = SupervisorLockGate(node, drive, [BASE_LOCK_TOPIC], 0.5, lambda: clock["now"])  # type: ignore[arg-type]
    arm = ArmLockGate(node, [ARM_LOCK_TOPIC], 0.5, lambda: clock["now"])  # type: ignore[arg-type]
    assert arm.locked()
    assert base.locked()
    node.subscriptions[BASE_LOCK_TOPIC](Msg(False))
    node.subscriptions[ARM_LOCK_TOPIC](Msg(False))
    assert not arm.locked()
    assert not base.locked()
    drive.start(drive.map.locations["kitchen"].pose(), 0.0)

    clock["now"] = 0.4
    node.subscriptions[BASE_LOCK_TOPIC](Msg(False))  # navigation lives on; the arm server died
    clock["now"] = 0.7
    base.enforce()
    arm.check()

    assert arm.held_by() == [ARM_LOCK_TOPIC]
    assert not base.locked()
    assert drive.state(0.7).driving


def test_a_dead_navigation_server_stops_the_base_and_leaves_the_arm_to_its_own_lock(
    drive: DriveSim,
) -> None:
    clock = {"now": 0.0}
    node = FakeNode()
    base = SupervisorLockGate(node, drive, [BASE_LOCK_TOPIC], 0.5, lambda: clock["now"])  # type: ignore[arg-type]
    arm = ArmLockGate(node, [ARM_LOCK_TOPIC], 0.5, lambda: clock["now"])  # type: ignore[arg-type]
    node.subscriptions[BASE_LOCK_TOPIC](Msg(False))
    node.subscriptions[ARM_LOCK_TOPIC](Msg(False))
    drive.start(drive.map.locations["kitchen"].pose(), 0.0)

    node.subscriptions[ARM_LOCK_TOPIC](Msg(True))  # the arm's server latched the stop
    assert arm.locked()
    assert drive.state(0.1).driving  # a locked arm holds no wheels
    clock["now"] = 0.9
    node.subscriptions[ARM_LOCK_TOPIC](Msg(False))
    base.enforce()

    assert base.locked()
    assert drive.state(0.9).status == "halted"
    assert not arm.locked()


def test_the_defaults_name_both_motion_servers_locks() -> None:
    settings = load_settings({"SIM_SUPERVISOR_LOCK": "on"})
    assert settings.supervisor_lock_topics == ("/robot/supervisor_lock",)
    assert settings.arm_lock_topics == ("/robot/supervisor_lock/manipulation",)
    assert load_settings({"SIM_ARM_LOCK_TOPICS": "/a, /b"}).arm_lock_topics == ("/a", "/b")
    with pytest.raises(ConfigError, match="SIM_ARM_LOCK_TOPICS"):
        load_settings({"SIM_ARM_LOCK_TOPICS": " , "})
