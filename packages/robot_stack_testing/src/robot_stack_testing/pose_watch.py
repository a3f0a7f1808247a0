"""AmclWatch: the robot's pose as robot-sim publishes it on ``/amcl_pose``, read from ROS.

Tests and benchmarks of motion read the world, not the brain's summary: when did the robot
stop moving? Each sample keeps the message's header stamp (robot-sim stamps with the system
clock, so stamps compare with ``time.time()``): a halt is dated by the robot's own messages,
not by when a loaded test process got round to reading them.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass
from typing import Any

STILL_M = 0.001
"""Two positions closer than this are the same (robot-sim republishes a halted pose exactly)."""


@dataclass(frozen=True)
class PoseSample:
    stamp: float
    x: float
    y: float


class AmclWatch:
    def __init__(self, topic: str = "/amcl_pose", keep: int = 4000) -> None:
        from geometry_msgs.msg import PoseWithCovarianceStamped
        from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

        from robot_ros_bridge import RosBridge

        self._mutex = threading.Lock()
        self._samples: list[PoseSample] = []
        self._keep = keep
        self._bridge = RosBridge("amcl_watch").start()
        qos = QoSProfile(
            depth=10,
            reliability=ReliabilityPolicy.BEST_EFFORT,  # matches AMCL's reliable + latched too
            durability=DurabilityPolicy.VOLATILE,
        )
        self._bridge.create_subscription(PoseWithCovarianceStamped, topic, self._on_pose, qos)

    def _on_pose(self, msg: Any) -> None:
        stamp = msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9
        sample = PoseSample(stamp, msg.pose.pose.position.x, msg.pose.pose.position.y)
        with self._mutex:
            self._samples.append(sample)
            del self._samples[: -self._keep]

    def samples(self) -> list[PoseSample]:
        with self._mutex:
            return list(self._samples)

    def latest(self) -> PoseSample | None:
        with self._mutex:
            return self._samples[-1] if self._samples else None

    def moving(self, window_s: float = 0.3) -> bool:
        """The newest samples (``window_s`` of stamps) show the robot moving."""
        recent = self._window(window_s)
        return len(recent) >= 2 and _dist(recent[0], recent[-1]) > STILL_M

    def halted_at(self, still_s: float = 0.5) -> float | None:
        """When the robot stopped, if it has stood still for at least ``still_s`` (by stamps)
        since: the stamp of the first sample at the final position. None while it moves, or
        before ``still_s`` of stillness were seen."""
        samples = self.samples()
        if not samples:
            return None
        last = samples[-1]
        first_still = last
        for sample in reversed(samples):
            if _dist(sample, last) > STILL_M:
                break
            first_still = sample
        if last.stamp - first_still.stamp < still_s:
            return None
        return first_still.stamp

    def _window(self, window_s: float) -> list[PoseSample]:
        samples = self.samples()
        if not samples:
            return []
        newest = samples[-1].stamp
        return [s for s in samples if s.stamp >= newest - window_s]

    def close(self) -> None:
        self._bridge.close()


def _dist(a: PoseSample, b: PoseSample) -> float:
    return float(((a.x - b.x) ** 2 + (a.y - b.y) ** 2) ** 0.5)
