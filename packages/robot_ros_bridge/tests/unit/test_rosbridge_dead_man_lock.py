"""The dead-man lock's semantics against twist_mux 4.3.0's rules (topic_handle.hpp,
twist_mux.cpp), as documented in robot_ros_bridge.dead_man_lock."""

import pytest

from robot_ros_bridge.dead_man_lock import (
    LOCK_PRIORITY,
    LOCK_TOPIC,
    LOCK_TYPE,
    TwistMuxLock,
    is_masked,
    lock_priority,
)


def test_a_lock_with_a_timeout_is_locked_before_its_first_message() -> None:
    assert TwistMuxLock(timeout_s=0.5).is_locked(now=1000.0)


def test_false_opens_the_lock_until_the_publisher_is_silent_longer_than_the_timeout() -> None:
    lock = TwistMuxLock(timeout_s=0.5)
    lock.on_message(False, now=10.0)

    assert not lock.is_locked(10.0)
    assert not lock.is_locked(10.5)  # twist_mux compares strictly: (now - stamp) > timeout
    assert lock.is_locked(10.5001)


def test_true_locks_at_once_whatever_the_timeout() -> None:
    lock = TwistMuxLock(timeout_s=0.5)
    lock.on_message(False, now=10.0)
    lock.on_message(True, now=10.1)

    assert lock.is_locked(10.1)


def test_the_last_message_wins_so_one_publisher_per_lock_topic() -> None:
    lock = TwistMuxLock(timeout_s=0.5)
    lock.on_message(True, now=10.0)  # a dead server's last word
    lock.on_message(False, now=10.05)  # another publisher on the same topic

    assert not lock.is_locked(10.1)


def test_a_lock_without_timeout_never_expires_and_is_no_dead_man_lock() -> None:
    lock = TwistMuxLock(timeout_s=0.0)

    assert not lock.is_locked(now=1e9)


def test_priorities_are_clamped_to_0_255_like_twist_mux() -> None:
    assert TwistMuxLock(priority=400).priority == 255
    assert TwistMuxLock(priority=-3).priority == 0


def test_the_lock_priority_is_the_highest_of_the_locked_locks() -> None:
    pause = TwistMuxLock(timeout_s=0.0, priority=100)
    supervisor = TwistMuxLock(timeout_s=0.5, priority=LOCK_PRIORITY)
    supervisor.on_message(False, now=1.0)

    assert lock_priority([pause, supervisor], now=1.2) == 0
    pause.on_message(True, now=1.2)
    assert lock_priority([pause, supervisor], now=1.3) == 100
    assert lock_priority([pause, supervisor], now=2.0) == 255  # the supervisor went silent


@pytest.mark.parametrize(("topic_priority", "masked"), [(10, True), (100, True), (254, True)])
def test_a_locked_255_lock_masks_every_velocity_input_below_255(
    topic_priority: int, masked: bool
) -> None:
    assert is_masked(topic_priority, LOCK_PRIORITY) is masked


def test_an_input_at_255_is_not_masked_by_a_255_lock_twist_mux_compares_strictly() -> None:
    assert not is_masked(255, LOCK_PRIORITY)
    assert is_masked(255, LOCK_PRIORITY, topic_expired=True)


def test_the_topic_and_type_are_the_contract() -> None:
    assert (LOCK_TOPIC, LOCK_TYPE) == ("/robot/supervisor_lock", "std_msgs/msg/Bool")
