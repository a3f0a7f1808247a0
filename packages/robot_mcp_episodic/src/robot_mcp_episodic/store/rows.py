"""Row <-> record conversions shared by the SQL adapters (column order matches the schemas)."""

from __future__ import annotations

import json
from collections.abc import Sequence
from typing import Any

from robot_mcp_episodic.store.base import Note, PoseSample, Sighting, Visit

SIGHTING_COLUMNS = (
    "id, robot_id, map, skill, label, first_seen, last_seen, count, best_score, box, "
    "x, y, yaw, place, absent_since"
)
POSE_COLUMNS = "id, robot_id, map, t, x, y, yaw, place"
NOTE_COLUMNS = "id, robot_id, map, t, kind, text, mission_id, place"
VISIT_COLUMNS = "id, robot_id, map, place, arrived, departed"


def sighting_params(s: Sighting) -> tuple[Any, ...]:
    box = json.dumps(s.box, separators=(",", ":")) if s.box is not None else None
    return (
        s.id, s.robot_id, s.map, s.skill, s.label, s.first_seen, s.last_seen, s.count,
        s.best_score, box, s.x, s.y, s.yaw, s.place, s.absent_since,
    )  # fmt: skip


def sighting_from_row(row: Sequence[Any]) -> Sighting:
    box = json.loads(row[9]) if row[9] else None
    return Sighting(
        id=row[0], robot_id=row[1], map=row[2], skill=row[3], label=row[4],
        first_seen=float(row[5]), last_seen=float(row[6]), count=int(row[7]),
        best_score=float(row[8]), box=box, x=row[10], y=row[11], yaw=row[12], place=row[13],
        absent_since=row[14],
    )  # fmt: skip


def pose_params(p: PoseSample) -> tuple[Any, ...]:
    return (p.robot_id, p.map, p.t, p.x, p.y, p.yaw, p.place)


def pose_from_row(row: Sequence[Any]) -> PoseSample:
    return PoseSample(
        id=int(row[0]), robot_id=row[1], map=row[2], t=float(row[3]), x=float(row[4]),
        y=float(row[5]), yaw=float(row[6]), place=row[7],
    )  # fmt: skip


def visit_params(v: Visit) -> tuple[Any, ...]:
    return (v.id, v.robot_id, v.map, v.place, v.arrived, v.departed)


def visit_from_row(row: Sequence[Any]) -> Visit:
    return Visit(row[0], row[1], row[2], row[3], float(row[4]), float(row[5]))


def note_params(n: Note) -> tuple[Any, ...]:
    return (n.id, n.robot_id, n.map, n.t, n.kind, n.text, n.mission_id, n.place)


def note_from_row(row: Sequence[Any]) -> Note:
    return Note(
        id=row[0], robot_id=row[1], map=row[2], t=float(row[3]), kind=row[4], text=row[5],
        mission_id=row[6], place=row[7],
    )  # fmt: skip
