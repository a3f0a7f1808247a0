"""What the UI's History panel shows, read from the episodic memory server (pure helpers).

The server's ``what_happened`` lists the sightings of a window (label, skill, first seen,
place); its ``last_seen`` adds what a row on the map needs (the robot's pose when it first saw
the thing, last seen, best score, count). The route calls both and :func:`sighting_rows`
joins them by sighting id, newest first. One thing seen at one place at the same time by two
skills (a detector and the scene describer's object list) is one row for the operator.
"""

from __future__ import annotations

import math
import re
from datetime import UTC, datetime
from typing import Any

from robot_mcp_kit.mcp_runtime import parse_tool_error

SERVER = "episodic"
DEFAULT_SINCE = "-1h"
MAX_LIMIT = 100
MAX_SINCE_CHARS = 40
LAST_SEEN_N = 50  # the server's maximum: every row of one label in a window of MAX_LIMIT rows
_RELATIVE = re.compile(r"^-(\d+(?:\.\d+)?)(s|m|min|h|d)$")
_UNIT_S = {"s": 1.0, "m": 60.0, "h": 3600.0, "d": 86400.0}
# A clock time today in the site's zone, as the episodic server reads it ("00:00" = since
# midnight): the server resolves it, so the brain never does clock arithmetic.
_CLOCK = re.compile(r"^([01]?\d|2[0-3]):[0-5]\d$")
SINCE_FORMS = (
    "a relative time (-30s, -10m, -2h, -1d), a clock time today in the site's time zone "
    "(00:00 = since midnight) or an ISO 8601 time (2026-11-24T15:00:00Z)"
)
QUERY_ERRORS = frozenset({"invalid_time", "invalid_range"})
SAME_SIGHTING_SLACK_S = 2.0  # two skills' intervals this close apart are one sighting


class HistoryError(Exception):
    """A request the panel cannot answer: ``status`` (422 / 502 / 503), a code, a sentence."""

    def __init__(self, status: int, error: str, detail: str, tool_code: str = "") -> None:
        super().__init__(detail)
        self.status = status
        self.error = error
        self.detail = detail
        self.tool_code = tool_code  # the episodic tool's own error code, if it sent one

    def body(self) -> dict[str, str]:
        return {"error": self.error, "detail": self.detail}


def not_connected() -> HistoryError:
    return HistoryError(
        503,
        "episodic_unavailable",
        "The episodic memory server is not connected, so the robot's history cannot be shown.",
    )


def check_since(text: str, now: float) -> str:
    """``since`` as the episodic server reads it, or a 422 that says which forms work."""
    value = text.strip()
    if not value or len(value) > MAX_SINCE_CHARS:
        raise HistoryError(422, "invalid_query", f"since must be {SINCE_FORMS}")
    relative = _RELATIVE.match(value)
    if relative is not None and float(relative[1]) * _UNIT_S[relative[2][0]] > now:
        raise HistoryError(422, "invalid_query", f"since {text!r} is before 1970: {SINCE_FORMS}")
    if relative is not None or _CLOCK.match(value):
        return value
    stamp = _epoch(value)
    if stamp is None:
        raise HistoryError(422, "invalid_query", f"since {text!r} is not a time: use {SINCE_FORMS}")
    if stamp > now:
        raise HistoryError(422, "invalid_query", f"since {text!r} is in the future")
    if stamp < 0:  # as the relative form above: the README's "further back than 1970"
        raise HistoryError(422, "invalid_query", f"since {text!r} is before 1970: {SINCE_FORMS}")
    return value


def check_limit(limit: int) -> int:
    if not 1 <= limit <= MAX_LIMIT:
        raise HistoryError(422, "invalid_query", f"limit must be between 1 and {MAX_LIMIT}")
    return limit


def tool_failure(tool: str, text: str) -> HistoryError:
    """An episodic tool error: a time the server cannot use is the caller's (422), anything
    else the server's (502), with its sentence."""
    parsed = parse_tool_error(text)
    if parsed is None:
        return HistoryError(502, "episodic_error", f"{tool}: {text.strip()[:300]}")
    code = parsed["error"]
    if code in QUERY_ERRORS:
        return HistoryError(422, "invalid_query", parsed["detail"], code)
    return HistoryError(502, "episodic_error", f"{tool}: {parsed['detail']}", code)


def labels_of(happened: dict[str, Any]) -> list[str]:
    """The distinct labels of the window's sightings, in the order they appear."""
    return list(dict.fromkeys(str(item["label"]) for item in _sightings(happened)))


def sighting_rows(happened: dict[str, Any], details: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """``what_happened``'s sightings, newest first, each joined with its ``last_seen`` result
    (``details``: every label's results) for the pose, last seen, score and count."""
    by_id = {str(r["id"]): r for answer in details for r in answer.get("results") or []}
    rows = []
    for item in reversed(_sightings(happened)):
        found = by_id.get(str(item["id"]), {})
        last = found.get("last_seen") or {}
        rows.append(
            {
                "id": str(item["id"]),
                "label": str(item["label"]),
                "skill": item.get("skill"),
                "first_seen": item["time"],
                "last_seen": last.get("time") or item.get("until"),
                "ago": item.get("ago"),
                "t": item.get("t"),
                "seen_for": found.get("seen_for"),
                "place": item.get("place"),
                "pose": _pose(found.get("robot_pose")),
                "score": found.get("best_score"),
                "count": found.get("count"),
                "skills": [item.get("skill")],
            }
        )
    return _one_row_per_sighting(rows)


def _one_row_per_sighting(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Rows of one label at one place whose intervals overlap are one sighting by several
    skills: the row kept is a scored one (a detector's, with a box and score) if any, listing
    every skill that saw it."""
    kept: list[dict[str, Any]] = []
    for row in rows:
        twin = next((k for k in kept if _same_sighting(k, row)), None)
        if twin is None:
            kept.append(row)
            continue
        skills = [*twin["skills"], *(s for s in row["skills"] if s not in twin["skills"])]
        if twin.get("score") is None and row.get("score") is not None:
            twin.clear()
            twin.update(row)
        twin["skills"] = skills
    return kept


def _same_sighting(a: dict[str, Any], b: dict[str, Any]) -> bool:
    if a["label"] != b["label"] or a.get("place") != b.get("place"):
        return False
    a_span, b_span = _interval(a), _interval(b)
    if a_span is None or b_span is None:
        return False
    slack = SAME_SIGHTING_SLACK_S
    return a_span[0] <= b_span[1] + slack and b_span[0] <= a_span[1] + slack


def _interval(row: dict[str, Any]) -> tuple[float, float] | None:
    first = _epoch(row.get("first_seen"))
    if first is None:
        return None
    last = _epoch(row.get("last_seen"))
    return first, last if last is not None else first


def _epoch(text: Any) -> float | None:
    """An ISO 8601 time as the episodic server reads it (no zone = UTC), else None."""
    if not isinstance(text, str):
        return None
    try:
        parsed = datetime.fromisoformat(text.replace("Z", "+00:00"))
    except ValueError:
        return None
    return (parsed if parsed.tzinfo else parsed.replace(tzinfo=UTC)).timestamp()


def _sightings(happened: dict[str, Any]) -> list[dict[str, Any]]:
    return [i for i in happened.get("items") or [] if i.get("kind") == "sighting"]


def _pose(pose: Any) -> dict[str, Any] | None:
    if not isinstance(pose, dict):
        return None
    try:
        x, y, yaw = (float(pose[k]) for k in ("x", "y", "yaw"))
    except (KeyError, TypeError, ValueError):
        return None
    if not all(math.isfinite(v) for v in (x, y, yaw)):
        return None
    return {"x": x, "y": y, "yaw": yaw, "map": pose.get("map")}
