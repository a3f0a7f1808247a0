"""The simulated gripper's rules: what a pick or a place may do where the robot is now. Pure
(no ROS): the action servers in ``manipulation_server.py`` ask it and apply its answers.

A pick succeeds only where it could on a robot: the gripper is empty, the base stands at a place,
the goal's detection was really published (topic + stamp, index or label) and is recent, the
object it names stands at that place now, it is in reach and the grasp holds. Injected faults
(``Faults``: the next grasps fail, labels out of reach) come from the node's parameters.
"""

from __future__ import annotations

import threading
from collections import deque
from collections.abc import Iterable
from dataclasses import dataclass, field

from robot_sim.world import MAX_OBJECTS_PER_PLACE, World

STAMP_TOLERANCE_NS = 1_000_000
"""A reference's stamp may differ this much from the message's (it crossed JSON as a float)."""
KEPT_PER_TOPIC = 20


@dataclass(frozen=True)
class Sighting:
    """One ``VisionDetectionArray`` as the gripper keeps it: labels and scores, no pixels."""

    topic: str
    stamp_ns: int
    labels: tuple[str, ...]
    scores: tuple[float, ...]


@dataclass(frozen=True)
class Reference:
    """A pick goal's ``DetectionRef``."""

    topic: str
    stamp_ns: int
    index: int = -1
    label: str = ""


@dataclass(frozen=True)
class Refusal:
    """Why a goal cannot (or did not) succeed: ``code`` is the Result constant's name."""

    code: str
    message: str
    not_yet: bool = False
    """The result may still be on its way (the goal and the data plane are separate channels)."""


@dataclass
class Faults:
    """Injected through parameters: ``fail_grasps`` next grasps fail; labels out of reach."""

    fail_grasps: int = 0
    out_of_reach: frozenset[str] = frozenset()


def same_thing(wanted: str, seen: str) -> bool:
    """Does a caller's label name the detection's ("package" ~ "yellow package")?"""
    a, b = wanted.strip().lower(), seen.strip().lower()
    return not a or a == b or a in b.split() or a in b or b in a


@dataclass
class Sightings:
    """The recent detection results per topic (thread-safe; bounded)."""

    kept: int = KEPT_PER_TOPIC
    _by_topic: dict[str, deque[Sighting]] = field(default_factory=dict)
    _lock: threading.Lock = field(default_factory=threading.Lock)

    def add(self, sighting: Sighting) -> None:
        with self._lock:
            self._by_topic.setdefault(sighting.topic, deque(maxlen=self.kept)).append(sighting)

    def of(self, topic: str) -> list[Sighting] | None:
        with self._lock:
            known = self._by_topic.get(topic)
            return None if known is None else list(known)


class Gripper:
    def __init__(self, world: World, max_age_s: float = 30.0) -> None:
        self.world = world
        self.max_age_s = max_age_s
        self.faults = Faults()
        self._lock = threading.Lock()

    def resolve(
        self, ref: Reference, results: Iterable[Sighting] | None, now_ns: int, max_age_s: float
    ) -> tuple[str, Refusal | None]:
        """The label of the referenced detection, or why there is none to pick."""
        if results is None:
            return "", Refusal(
                "DETECTION_NOT_FOUND",
                f"no detection result was received on {ref.topic}",
                not_yet=True,
            )
        match = next(
            (s for s in results if abs(s.stamp_ns - ref.stamp_ns) <= STAMP_TOLERANCE_NS), None
        )
        if match is None:
            return "", Refusal(
                "DETECTION_NOT_FOUND",
                f"no detection result with that stamp on {ref.topic} (it may be too old)",
                not_yet=True,
            )
        if ref.index >= 0:
            if ref.index >= len(match.labels):
                return "", Refusal(
                    "DETECTION_NOT_FOUND",
                    f"that result has {len(match.labels)} detections, no index {ref.index}",
                )
            label = match.labels[ref.index]
            if not same_thing(ref.label, label):
                return "", Refusal(
                    "DETECTION_NOT_FOUND",
                    f"detection {ref.index} is a {label}, not a {ref.label}",
                )
        else:
            wanted = [
                (score, label)
                for label, score in zip(match.labels, match.scores, strict=True)
                if same_thing(ref.label, label)
            ]
            if not wanted:
                return "", Refusal("DETECTION_NOT_FOUND", f"that result shows no {ref.label}")
            label = max(wanted)[1]
        limit = max_age_s if max_age_s > 0 else self.max_age_s
        age = (now_ns - match.stamp_ns) / 1e9
        if age > limit:
            return label, Refusal(
                "DETECTION_STALE",
                f"the {label} was seen {age:.0f} s ago (more than {limit:g} s): it may have moved",
            )
        return label, None

    def arm_ready(self, driving: bool) -> Refusal | None:
        """Why the arm cannot start a pick at all (checked before the detection), or None."""
        held = self.world.held()
        if held is not None:
            return Refusal("ALREADY_HOLDING", f"the gripper already holds the {held}")
        if driving:
            return Refusal("ARM_NOT_READY", "the base is moving; the arm waits until it stands")
        return None

    def check_pick(self, place: str | None, label: str) -> Refusal | None:
        """Why the arm cannot pick ``label`` where the robot stands, or None."""
        if place is None:
            return Refusal(
                "DETECTION_NOT_FOUND", f"the robot is not at a place where a {label} could be"
            )
        if label not in self.world.objects_at(place):
            return Refusal(
                "DETECTION_NOT_FOUND", f"there is no {label} in reach at {place} (not in view here)"
            )
        with self._lock:
            if label in self.faults.out_of_reach:
                return Refusal("OUT_OF_REACH", f"the {label} is out of the arm's reach here")
        return None

    def grasp_holds(self) -> bool:
        """False when an injected failure is due (used up by this grasp)."""
        with self._lock:
            if self.faults.fail_grasps > 0:
                self.faults.fail_grasps -= 1
                return False
            return True

    def check_place(self, place: str | None, driving: bool) -> Refusal | None:
        held = self.world.held()
        if held is None:
            return Refusal("NOTHING_HELD", "the gripper holds nothing")
        if driving:
            return Refusal("ARM_NOT_READY", "the base is moving; the arm waits until it stands")
        if place is None:
            return Refusal("NO_SURFACE", "the robot is not at a place with a surface in reach")
        if len(self.world.objects_at(place)) >= MAX_OBJECTS_PER_PLACE:
            return Refusal("NO_SURFACE", f"there is no free space at {place}")
        return None

    def set_faults(
        self, fail_grasps: int | None = None, out_of_reach: list[str] | None = None
    ) -> None:
        with self._lock:
            if fail_grasps is not None:
                self.faults.fail_grasps = fail_grasps
            if out_of_reach is not None:
                self.faults.out_of_reach = frozenset(out_of_reach)
