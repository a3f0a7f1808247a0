"""The lock gate dates a halt as twist_mux would, not by when a starved robot-sim gets to it."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import pytest

from robot_sim.config import SimSettings
from robot_sim.drive import DriveSim
from robot_sim.supervisor_lock import SupervisorLockGate
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
    clock["now"] = 0.9
    node.subscriptions["/lock"](Msg(False))  # the motion server's last word
    gate.enforce()

    clock["now"] = 3.0  # robot-sim starved for 2 s; the lock ran out at 1.4
    gate.enforce()

    state = drive.state(3.0)
    assert state.status == "halted"
    start = drive.map.locations[drive.map.start].pose()
    assert state.pose.distance_to(start) == pytest.approx(drive.speed * 1.4, abs=0.01)


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
