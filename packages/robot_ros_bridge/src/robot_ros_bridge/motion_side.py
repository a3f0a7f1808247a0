"""MotionRosSide: a motion server's ROS side (issue 27, issue 35) — its bridge and, when it is
supervised, its dead-man lock on a topic of its own and the graph watcher that raises its alarms
(a second publisher of that lock topic, an open lock this process did not send, a goal of its
actions not its own while motion is refused). The domain's adapters are built on
``side.bridge``; what else the domain watches it adds to ``side.watcher``.

Imports rclpy: only a composition root imports this module, lazily.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Protocol

from robot_ros_bridge.bridge import RosBridge
from robot_ros_bridge.graph_watch import GraphWatcher
from robot_ros_bridge.lock_publisher import SupervisorLockPublisher


class Supervised(Protocol):
    """What the ROS side needs of the server's supervision (``robot_mcp_kit``'s)."""

    def locked(self) -> bool: ...

    def raise_alarm(self, code: str, detail: str) -> object: ...

    def refusal(self) -> object | None: ...


class LockSettings(Protocol):
    @property
    def lock_topic(self) -> str: ...

    @property
    def lock_hz(self) -> float: ...

    @property
    def allowed_goal_clients(self) -> tuple[str, ...]: ...


@dataclass(frozen=True)
class DeadManLock:
    """The lock a supervised motion server publishes: ``locked()`` its value, ``raise_alarm``
    where the watcher's alarms go, ``shared_code`` the alarm of a second publisher on it;
    while ``refused()``, a goal of its actions not its own is ``foreign_code`` (other clients
    named in ``allowed_clients`` excepted)."""

    topic: str
    rate_hz: float
    locked: Callable[[], bool]
    raise_alarm: Callable[[str, str], object]
    refused: Callable[[], bool]
    shared_code: str
    foreign_code: str
    allowed_clients: tuple[str, ...]
    what: str

    @classmethod
    def of(
        cls,
        supervision: Supervised,
        settings: LockSettings,
        codes: tuple[str, str],
        what: str,
    ) -> DeadManLock:
        """``codes``: the alarms of a shared lock topic and of a foreign goal client."""
        return cls(
            settings.lock_topic,
            settings.lock_hz,
            supervision.locked,
            supervision.raise_alarm,
            lambda: supervision.refusal() is not None,
            codes[0],
            codes[1],
            settings.allowed_goal_clients,
            what,
        )


@dataclass
class MotionRosSide:
    bridge: RosBridge
    lock: SupervisorLockPublisher | None = None
    watcher: GraphWatcher | None = None
    spec: DeadManLock | None = None

    @contextmanager
    def closed_on_error(self) -> Iterator[MotionRosSide]:
        """Build the domain's adapters inside: an error closes the side before it propagates."""
        try:
            yield self
        except BaseException:
            self.close()
            raise

    def watch_goals(
        self,
        action: str,
        ours: Callable[[bytes], bool],
        cancel_all_now: Callable[[], object],
        what: str,
    ) -> None:
        """While motion is refused, a goal of ``action`` not ``ours`` (or another client of it)
        is alarmed and everything it runs cancelled (``cancel_all_now``); unsupervised: nothing."""
        if self.watcher is None or self.spec is None:
            return
        self.watcher.watch_goals(
            action,
            self.spec.foreign_code,
            ours=ours,
            stopped=self.spec.refused,
            cancel_all_now=cancel_all_now,
            allowed_clients=self.spec.allowed_clients,
            what=what,
        )

    def publish_lock(self) -> None:
        if self.lock is not None:
            self.lock.publish()

    def close(self) -> None:
        if self.lock is not None:
            self.lock.close()  # the lock falls silent first: twist_mux locks
        if self.watcher is not None:
            self.watcher.close()
        self.bridge.close()


def open_motion_side(node_name: str, lock: DeadManLock | None = None) -> MotionRosSide:
    """Start the bridge (node ``node_name``) and, with ``lock``, the lock and its watcher."""
    bridge = RosBridge(node_name).start()
    if lock is None:
        return MotionRosSide(bridge)
    try:
        publisher = SupervisorLockPublisher(
            bridge, lock.locked, topic=lock.topic, rate_hz=lock.rate_hz
        )
        watcher = GraphWatcher(bridge, lock.raise_alarm)
        watcher.watch_publishers(lock.topic, lock.shared_code, own=True, what=lock.what)
        watcher.watch_lock(
            lock.topic,
            lock.shared_code,
            locked=lock.locked,
            last_open_at=publisher.last_open_at,
            what=lock.what,
        )
    except BaseException:
        bridge.close()
        raise
    return MotionRosSide(bridge, publisher, watcher, lock)
