"""The indexer: turns the incoming stream (detections, skill outputs, poses, notes) into index
rows, in memory, and hands them to the store in batches (:meth:`Indexer.flush`).

Callbacks only touch memory under a short lock, so recording never waits for the database;
a background thread calls ``flush`` every ``flush_s`` seconds (what a crash loses).

Sightings: one open interval per (skill, label). A detection extends it while the label keeps
being seen at the same named place with gaps shorter than ``gap_s``; after a longer gap, or at
another place, a new interval starts (the old one keeps its first and last seen). When the
same skill looks at the same place again and the label is missing for ``gap_s``, the interval
gets ``absent_since``.

Poses: kept when the robot moved >= ``min_move_m``, turned >= ``min_turn_deg`` or every
``max_pose_gap_s`` seconds.
"""

from __future__ import annotations

import dataclasses
import math
import threading
import time
import uuid
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import structlog

from robot_mcp_episodic.places import Places
from robot_mcp_episodic.store.base import EpisodicStore, Note, PoseSample, Sighting, Visit

logger = structlog.get_logger(__name__)

NOTE_KINDS = (
    "scene",
    "mission_started",
    "mission_finished",
    "user",
    "robot",
    "event",
    "observation",
)


@dataclass(frozen=True)
class IndexRules:
    gap_s: float = 10.0
    min_move_m: float = 0.25
    min_turn_deg: float = 15.0
    max_pose_gap_s: float = 10.0


@dataclass(frozen=True)
class Pose:
    t: float
    x: float
    y: float
    yaw: float


OBJECT_LIST_OUTPUTS = ("scene_objects", "objects")  # semantic outputs that list labels


def new_id(prefix: str) -> str:
    return f"{prefix}-{uuid.uuid4().hex[:16]}"


class Indexer:
    def __init__(
        self,
        store: EpisodicStore,
        places: Places,
        rules: IndexRules | None = None,
        *,
        clock: Callable[[], float] = time.time,
    ) -> None:
        self._store = store
        self._places = places
        self._rules = rules or IndexRules()
        self._clock = clock
        self._lock = threading.Lock()
        self._flush_lock = threading.Lock()
        self._open: dict[tuple[str, str], Sighting] = {}
        self._loaded: set[tuple[str, str]] = set()
        self._dirty: dict[str, Sighting] = {}
        self._poses: list[PoseSample] = []
        self._visit: Visit | None = None
        self._dirty_visits: dict[str, Visit] = {}
        self._notes: list[Note] = []
        self._pose: Pose | None = None
        self._kept_pose: Pose | None = None
        self._outputs: dict[tuple[str, str], str] = {}
        self.last_write: dict[str, float] = {}

    @property
    def map(self) -> str:
        return self._places.map

    @property
    def robot_id(self) -> str:
        return self._store.robot_id

    def current_place(self) -> str | None:
        with self._lock:
            pose = self._pose
        return self._places.locate(pose.x, pose.y) if pose else None

    # -- stream inputs ---------------------------------------------------------------------
    def on_pose(self, t: float, x: float, y: float, yaw: float) -> None:
        pose = Pose(t, x, y, yaw)
        place = self._places.locate(x, y)
        with self._lock:
            self._pose = pose
            self.last_write["pose"] = t
            self._stay(place, t)
            if not self._keep(pose):
                return
            self._kept_pose = pose
            self._poses.append(PoseSample(self.robot_id, self.map, t, x, y, yaw, place))

    def _stay(self, place: str | None, t: float) -> None:
        """Extend the current stay, or end it and start one at the new place."""
        visit = self._visit
        if visit is not None and visit.place == place and t >= visit.departed:
            visit.departed = t
        elif place is None:
            self._visit = None
            return
        else:
            visit = self._visit = Visit(new_id("v"), self.robot_id, self.map, place, t, t)
        self._dirty_visits[visit.id] = visit

    def _keep(self, pose: Pose) -> bool:
        last = self._kept_pose
        if last is None:
            return True
        turned = abs(math.degrees(math.remainder(pose.yaw - last.yaw, math.tau)))
        return (
            math.hypot(pose.x - last.x, pose.y - last.y) >= self._rules.min_move_m
            or turned >= self._rules.min_turn_deg
            or pose.t - last.t >= self._rules.max_pose_gap_s
        )

    def on_detections(self, skill: str, t: float, detections: Sequence[Mapping[str, Any]]) -> None:
        """One frame of ``skill`` (an empty frame is evidence of absence)."""
        best: dict[str, Mapping[str, Any]] = {}
        for det in detections:
            label = str(det.get("label", "")).strip()
            if label and float(det.get("score", 0.0)) >= float(
                best.get(label, {}).get("score", -1.0)
            ):
                best[label] = det
        unloaded = [(skill, label) for label in best if (skill, label) not in self._loaded]
        resumed = {key: self._store.latest_sighting(*key) for key in unloaded}
        with self._lock:
            self.last_write[f"detections:{skill}"] = t
            pose = self._pose
            place = self._places.locate(pose.x, pose.y) if pose else None
            for key, previous in resumed.items():
                self._loaded.add(key)
                if previous is not None and key not in self._open:
                    self._open[key] = previous
            missing = [key for key in self._open if key[0] == skill and key[1] not in best]
            for label, det in best.items():
                self._see(skill, label, det, t, pose, place)
            if place is not None:
                for key in missing:
                    self._absent(self._open[key], t, place)

    def _see(
        self,
        skill: str,
        label: str,
        det: Mapping[str, Any],
        t: float,
        pose: Pose | None,
        place: str | None,
    ) -> None:
        score = float(det.get("score", 0.0))
        box = det.get("box")
        current = self._open.get((skill, label))
        if (
            current is not None
            and t - current.last_seen <= self._rules.gap_s
            and (current.place == place or current.place is None or place is None)
            and current.absent_since is None
            and t >= current.last_seen
        ):
            current.last_seen = t
            current.count += 1
            if current.place is None and place is not None and pose is not None:
                # First seen before the robot knew where it was: where it is now is better.
                current.place, current.x, current.y, current.yaw = place, pose.x, pose.y, pose.yaw
            if score > current.best_score:
                current.best_score = round(score, 4)
                current.box = dict(box) if box else None
        else:
            current = Sighting(
                id=new_id("s"),
                robot_id=self.robot_id,
                map=self.map,
                skill=skill,
                label=label,
                first_seen=t,
                last_seen=t,
                count=1,
                best_score=round(score, 4),
                box=dict(box) if box else None,
                x=pose.x if pose else None,
                y=pose.y if pose else None,
                yaw=pose.yaw if pose else None,
                place=place,
            )
            self._open[(skill, label)] = current
        self._dirty[current.id] = current

    def _absent(self, sighting: Sighting, t: float, place: str) -> None:
        if (
            sighting.place == place
            and sighting.absent_since is None
            and t - sighting.last_seen >= self._rules.gap_s
        ):
            sighting.absent_since = t
            self._dirty[sighting.id] = sighting

    def on_output(self, skill: str, output: str, t: float, value: Any) -> None:
        """A semantic skill output becomes an ``observation`` note when its value changes; a
        list of objects in view (the scene describer's ``scene_objects``) is also a frame of
        sightings, so what the robot saw is remembered even when no detector ran."""
        if output in OBJECT_LIST_OUTPUTS and isinstance(value, list):
            labels = [str(item).strip() for item in value if str(item).strip()]
            self.on_detections(skill, t, [{"label": label, "score": 0.0} for label in labels])
        text = value if isinstance(value, str) else _compact(value)
        with self._lock:
            if self._outputs.get((skill, output)) == text:
                return
            self._outputs[(skill, output)] = text
        kind = (
            "scene"
            if output in ("description", "scene_description", "caption")
            else ("observation")
        )
        self.note(kind, f"{skill} {output}: {text}", t=t)

    def note(
        self, kind: str, text: str, mission_id: str | None = None, t: float | None = None
    ) -> Note:
        stamp = self._clock() if t is None else t
        note = Note(
            new_id("n"), self.robot_id, self.map, stamp, kind, text, mission_id,
            self.current_place(),
        )  # fmt: skip
        with self._lock:
            self._notes.append(note)
            self.last_write[f"notes:{kind}"] = stamp
        return note

    # -- persistence -----------------------------------------------------------------------
    def flush(self) -> int:
        """Write what accumulated since the last flush; returns the number of rows."""
        with self._flush_lock:
            with self._lock:
                sightings = [dataclasses.replace(s) for s in self._dirty.values()]
                visits = [dataclasses.replace(v) for v in self._dirty_visits.values()]
                poses, notes = self._poses, self._notes
                self._dirty, self._poses, self._notes = {}, [], []
                self._dirty_visits = {}
            started = time.perf_counter()
            try:
                # Idempotent writes first: if the pose insert fails, a retry duplicates nothing.
                self._store.save_notes(notes)
                self._store.save_sightings(sightings)
                self._store.save_visits(visits)
                self._store.save_poses(poses)
            except Exception:
                with self._lock:  # keep them for the next flush; nothing is lost
                    for s in sightings:
                        self._dirty.setdefault(s.id, s)
                    for v in visits:
                        self._dirty_visits.setdefault(v.id, v)
                    self._poses[:0] = poses
                    self._notes[:0] = notes
                raise
            rows = len(sightings) + len(visits) + len(poses) + len(notes)
            if rows:
                logger.debug(
                    "episodic_flushed",
                    sightings=len(sightings),
                    poses=len(poses),
                    notes=len(notes),
                    duration_ms=round((time.perf_counter() - started) * 1000, 2),
                )
            return rows

    def forget_open(self, sighting_ids: set[str], visit_ids: set[str] | None = None) -> None:
        """Drop open intervals and stays that were just forgotten (so they are not written
        back)."""
        visit_ids = visit_ids or set()
        with self._lock:
            if self._visit is not None and self._visit.id in visit_ids:
                self._visit = None
            for vid in visit_ids:
                self._dirty_visits.pop(vid, None)
            for key, sighting in list(self._open.items()):
                if sighting.id in sighting_ids:
                    del self._open[key]
            for sid in sighting_ids:
                self._dirty.pop(sid, None)


def _compact(value: Any) -> str:
    import json

    return json.dumps(value, ensure_ascii=False, separators=(",", ":"), default=str)
