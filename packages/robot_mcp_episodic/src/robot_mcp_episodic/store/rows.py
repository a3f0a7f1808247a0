"""Row <-> record conversions shared by the SQL adapters (rows come back in the column order
of :mod:`.schema`; parameters are named after the columns)."""

from __future__ import annotations

import json
from collections.abc import Sequence
from typing import Any

from robot_mcp_episodic.store.base import Note, PoseSample, Sighting, Visit


def sighting_params(s: Sighting) -> dict[str, Any]:
    box = json.dumps(s.box, separators=(",", ":")) if s.box is not None else None
    return {
        "id": s.id, "robot_id": s.robot_id, "map": s.map, "skill": s.skill, "label": s.label,
        "first_seen": s.first_seen, "last_seen": s.last_seen, "count": s.count,
        "best_score": s.best_score, "box": box, "x": s.x, "y": s.y, "yaw": s.yaw,
        "place": s.place, "absent_since": s.absent_since,
    }  # fmt: skip


def sighting_from_row(row: Sequence[Any]) -> Sighting:
    box = json.loads(row[9]) if row[9] else None
    return Sighting(
        id=row[0], robot_id=row[1], map=row[2], skill=row[3], label=row[4],
        first_seen=float(row[5]), last_seen=float(row[6]), count=int(row[7]),
        best_score=float(row[8]), box=box, x=row[10], y=row[11], yaw=row[12], place=row[13],
        absent_since=row[14],
    )  # fmt: skip


def pose_params(p: PoseSample) -> dict[str, Any]:
    return {
        "robot_id": p.robot_id, "map": p.map, "t": p.t, "x": p.x, "y": p.y, "yaw": p.yaw,
        "place": p.place,
    }  # fmt: skip


def pose_from_row(row: Sequence[Any]) -> PoseSample:
    return PoseSample(
        id=int(row[0]), robot_id=row[1], map=row[2], t=float(row[3]), x=float(row[4]),
        y=float(row[5]), yaw=float(row[6]), place=row[7],
    )  # fmt: skip


def visit_params(v: Visit) -> dict[str, Any]:
    return {
        "id": v.id, "robot_id": v.robot_id, "map": v.map, "place": v.place,
        "arrived": v.arrived, "departed": v.departed,
    }  # fmt: skip


def visit_from_row(row: Sequence[Any]) -> Visit:
    return Visit(row[0], row[1], row[2], row[3], float(row[4]), float(row[5]))


def note_params(n: Note) -> dict[str, Any]:
    return {
        "id": n.id, "robot_id": n.robot_id, "map": n.map, "t": n.t, "kind": n.kind,
        "text": n.text, "mission_id": n.mission_id, "place": n.place,
    }  # fmt: skip


def note_from_row(row: Sequence[Any]) -> Note:
    return Note(
        id=row[0], robot_id=row[1], map=row[2], t=float(row[3]), kind=row[4], text=row[5],
        mission_id=row[6], place=row[7],
    )  # fmt: skip
