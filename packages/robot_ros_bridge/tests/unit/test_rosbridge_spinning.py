"""The spin loop is a process boundary: an entity destroyed mid-wait (rclpy's InvalidHandle, which
took the vision node down as a skill's publishers were destroyed) or a failing callback is logged
and spinning goes on; Ctrl-C and an external shutdown end it."""

from __future__ import annotations

import pytest
from rclpy.exceptions import InvalidHandle
from rclpy.executors import ExternalShutdownException

from robot_ros_bridge.spinning import spin_until_shutdown


class Executor:
    """Raises each of ``raises`` from one ``spin()`` in turn, then stops the loop."""

    def __init__(self, *raises: BaseException) -> None:
        self.raises = list(raises)
        self.spins = 0

    def spin(self) -> None:
        self.spins += 1
        if self.raises:
            raise self.raises.pop(0)

    def running(self) -> bool:
        return self.spins <= 2 or bool(self.raises)


def test_a_destroyed_entity_or_a_failing_callback_does_not_end_the_spin() -> None:
    executor = Executor(InvalidHandle("destruction was requested"), RuntimeError("a callback"))

    spin_until_shutdown(executor, executor.running)

    assert executor.spins == 3  # spun again after each


@pytest.mark.parametrize("stop", [KeyboardInterrupt(), ExternalShutdownException()])
def test_ctrl_c_and_an_external_shutdown_end_it(stop: BaseException) -> None:
    executor = Executor(stop)
    with pytest.raises(type(stop)):
        spin_until_shutdown(executor, lambda: True)
    assert executor.spins == 1


def test_an_error_during_shutdown_ends_it_quietly() -> None:
    executor = Executor(RuntimeError("context shut down"))
    states = iter([True, False])

    spin_until_shutdown(executor, lambda: next(states))

    assert executor.spins == 1
