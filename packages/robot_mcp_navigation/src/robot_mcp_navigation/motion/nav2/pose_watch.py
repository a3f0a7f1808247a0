"""PoseContinuity: notices a pose that comes back far from where the robot was last seen
(pure; the caller passes the arrival time).

A restarted base (robot-sim, a relaunched AMCL) publishes its pose again after a silence,
often somewhere else (the dock, the initial pose). A pose that arrives more than ``gap_s``
after the previous one and more than ``jump_m`` away from it is a **relocation**: get_pose
reports it, so a map never teleports the robot's marker without saying so. A pose topic that
is quiet while the robot stands still (AMCL publishes only when it updates) and resumes where
it was is no relocation.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass

from robot_mcp_navigation.motion.base import Pose

RELOCATION_GAP_S = 1.0
RELOCATION_JUMP_M = 0.5


@dataclass(frozen=True)
class Relocation:
    before: Pose
    after: Pose
    at: float
    """When the pose came back (``time.monotonic()``)."""
    silent_s: float

    @property
    def distance_m(self) -> float:
        return self.before.distance_to(self.after)


class PoseContinuity:
    def __init__(self, gap_s: float = RELOCATION_GAP_S, jump_m: float = RELOCATION_JUMP_M) -> None:
        self.gap_s = gap_s
        self.jump_m = jump_m
        self._mutex = threading.Lock()
        self._last: tuple[Pose, float] | None = None
        self._relocation: Relocation | None = None

    def observe(self, pose: Pose, at: float) -> Relocation | None:
        """Record one pose; the relocation it makes, if any."""
        with self._mutex:
            previous, self._last = self._last, (pose, at)
            if previous is None:
                return None
            before, then = previous
            if at - then <= self.gap_s or before.distance_to(pose) <= self.jump_m:
                return None
            self._relocation = Relocation(before, pose, at, at - then)
            return self._relocation

    @property
    def relocation(self) -> Relocation | None:
        """The latest relocation seen (None: never)."""
        with self._mutex:
            return self._relocation
