"""The dead-man lock in twist_mux's form (pure: no rclpy; the clock reading is passed in).

Matched against twist_mux **4.3.0** (ros-teleop/twist_mux, ``include/twist_mux/topic_handle.hpp``
and ``src/twist_mux.cpp``), the velocity multiplexer a ROS 2 robot runs in front of its base
controller:

- A lock is a ``std_msgs/Bool`` topic with a ``priority`` (clamped to 0..255) and a
  ``timeout`` (seconds). ``LockTopicHandle::isLocked() = hasExpired() || msg.data``.
- ``hasExpired() = timeout > 0 && (now - stamp) > timeout`` (strictly greater); the stamp
  starts at 0, so a lock with a timeout is **locked until its first message** and locked again
  once its publisher is **silent longer than the timeout**. A timeout of 0 never expires (a
  lock that is then open until someone publishes ``true``: not a dead-man lock).
- The lock priority is the highest priority among the locks that are locked (0 if none); a
  velocity topic is masked when it expired or ``its priority < lock priority``. With a
  priority-255 lock locked every input below 255 is masked: twist_mux forwards no velocity
  command at all, and the base controller's own command timeout stops the wheels.
- twist_mux subscribes locks with ``rclcpp::SystemDefaultsQoS()`` (reliable, volatile):
  a lock publisher must be reliable, or it never matches.
- Each lock topic needs exactly one publisher: twist_mux keeps the last message from any
  publisher, so a live server's ``false`` would hide a dead one's silence. One lock topic per
  motion server, one twist_mux lock entry per topic.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

LOCK_TOPIC = "/robot/supervisor_lock"
"""Navigation's lock topic (``std_msgs/msg/Bool``; ``true`` = locked)."""
LOCK_TYPE = "std_msgs/msg/Bool"
LOCK_PRIORITY = 255
"""Masks every velocity input of twist_mux below 255."""
LOCK_TIMEOUT_S = 0.5
"""twist_mux's ``timeout`` for the lock entry: silent this long = locked."""
LOCK_RATE_HZ = 20.0
"""How often a motion server publishes its lock (at least 10 Hz, well inside the timeout)."""
MIN_LOCK_RATE_HZ = 10.0
TWIST_MUX_RELEASE = "4.3.0"


def clamp_priority(priority: int) -> int:
    return max(0, min(255, int(priority)))


@dataclass
class TwistMuxLock:
    """One lock entry, as twist_mux's ``LockTopicHandle`` keeps it."""

    timeout_s: float = LOCK_TIMEOUT_S
    priority: int = LOCK_PRIORITY
    stamp: float | None = None
    """When the last message arrived (None: never, twist_mux's stamp 0)."""
    data: bool = False
    """The last message's value (twist_mux's default-constructed message: false)."""

    def __post_init__(self) -> None:
        if self.timeout_s < 0:
            raise ValueError("timeout_s must be >= 0")
        self.priority = clamp_priority(self.priority)

    def on_message(self, data: bool, now: float) -> None:
        self.stamp = now
        self.data = bool(data)

    def has_expired(self, now: float) -> bool:
        if self.timeout_s <= 0:
            return False
        return self.stamp is None or (now - self.stamp) > self.timeout_s

    def is_locked(self, now: float) -> bool:
        return self.has_expired(now) or self.data


def lock_priority(locks: Iterable[TwistMuxLock], now: float) -> int:
    """``TwistMux::getLockPriority``: the highest priority of the locks that are locked."""
    return max((lock.priority for lock in locks if lock.is_locked(now)), default=0)


def is_masked(topic_priority: int, lock_prio: int, topic_expired: bool = False) -> bool:
    """``VelocityTopicHandle::isMasked``: a velocity input twist_mux does not forward."""
    return topic_expired or clamp_priority(topic_priority) < lock_prio
