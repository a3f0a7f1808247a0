"""ReadinessTracker: a service counts as settled only after being continuously ready."""

import pytest

from robot_ros_bridge.bridge import ReadinessTracker


class _Client:
    """Any weak-referenceable object stands in for an rclpy client."""


def test_a_service_is_settled_only_after_being_ready_for_the_settle_time() -> None:
    tracker = ReadinessTracker(settle_s=1.0)
    client = _Client()
    assert tracker.settled_at(client, ready=False, now=10.0) is None
    assert tracker.settled_at(client, ready=True, now=10.5) == 11.5
    assert tracker.settled_at(client, ready=True, now=11.7) == 11.5


def test_a_service_that_disappears_must_settle_again() -> None:
    tracker = ReadinessTracker(settle_s=1.0)
    client = _Client()
    tracker.observe(client, ready=True, now=0.0)
    assert tracker.observe(client, ready=False, now=5.0) is None
    assert tracker.settled_at(client, ready=True, now=6.0) == 7.0


def test_each_client_is_tracked_on_its_own() -> None:
    tracker = ReadinessTracker(settle_s=0.5)
    first, second = _Client(), _Client()
    tracker.observe(first, ready=True, now=1.0)
    assert tracker.settled_at(second, ready=True, now=3.0) == 3.5
    assert tracker.settled_at(first, ready=True, now=3.0) == 1.5


def test_a_negative_settle_time_is_refused() -> None:
    with pytest.raises(ValueError, match="settle_s"):
        ReadinessTracker(settle_s=-0.1)
