"""The episodic memory's answers (the tools' logic): times and places are resolved here, so the
model never does time arithmetic, and every answer carries ISO times, "N s ago" and record ids.

Errors the caller can fix raise :class:`EpisodicError` (code ``invalid_time``,
``unknown_place``, ``invalid_range``, ``invalid_argument``); the server turns them into tool
errors.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any
from zoneinfo import ZoneInfo

import structlog

from robot_mcp_episodic.bags import BagRecorder
from robot_mcp_episodic.ingest import NOTE_KINDS, Indexer
from robot_mcp_episodic.matching import corrected_query, label_matches, matching_labels, words
from robot_mcp_episodic.places import Places, UnknownPlaceError
from robot_mcp_episodic.store.base import EpisodicStore, Note, PoseSample, Sighting, Visit
from robot_mcp_episodic.timeparse import (
    UTC_ZONE,
    TimeError,
    ago,
    clock_time,
    duration,
    iso,
    local_clock,
    parse_time,
)

logger = structlog.get_logger(__name__)

DIGEST_KINDS = ("sightings", "scene", "missions", "conversation", "places", "notes")
_NOTE_GROUPS = {
    "scene": ("scene", "observation"),
    "missions": ("mission_started", "mission_finished"),
    "conversation": ("user", "robot"),
    "notes": ("event",),
}
MISSION_KINDS = ("mission_started", "mission_finished")
POSE_NEAR_S = 120.0
RECEIVE_MARGIN_S = 2.0
EPOCH_START = 0.0


@dataclass(frozen=True)
class _ForgetRows:
    sightings: list[Sighting]
    notes: list[Note]
    poses: list[PoseSample] = field(default_factory=list)
    visits: list[Visit] = field(default_factory=list)

    def counts(self) -> dict[str, int]:
        return {
            "sightings": len(self.sightings), "notes": len(self.notes),
            "poses": len(self.poses), "visits": len(self.visits),
        }  # fmt: skip


class EpisodicError(Exception):
    def __init__(self, code: str, detail: str) -> None:
        super().__init__(detail)
        self.code = code
        self.detail = detail


@dataclass(frozen=True)
class Retention:
    bags_h: float
    index_d: float
    max_mb: float
    flush_s: float


class Episodic:
    def __init__(
        self,
        store: EpisodicStore,
        indexer: Indexer,
        places: Places,
        retention: Retention,
        bags: BagRecorder | None = None,
        *,
        clock: Callable[[], float] = time.time,
        zone: ZoneInfo = UTC_ZONE,
    ) -> None:
        self.store = store
        self.zone = zone
        self.indexer = indexer
        self.places = places
        self.retention = retention
        self.bags = bags
        self._clock = clock

    # -- argument resolution ---------------------------------------------------------------
    def _time(self, name: str, text: str | float | None, now: float) -> float:
        try:
            return parse_time(text, now, self.zone)
        except TimeError as exc:
            raise EpisodicError("invalid_time", f"{name}: {exc}") from None

    def _range(self, start: str | None, end: str | None, now: float) -> tuple[float, float]:
        begin = self._time("start", start, now) if start else EPOCH_START
        finish = self._time("end", end, now)
        if finish < begin:
            raise EpisodicError(
                "invalid_range",
                f"end ({iso(finish)}) is before start ({iso(begin)}); swap them or widen the range",
            )
        return begin, finish

    def _place(self, place: str | None) -> str | None:
        if place is None or not place.strip():
            return None
        try:
            return self.places.resolve(place)
        except UnknownPlaceError as exc:
            raise EpisodicError("unknown_place", str(exc)) from None

    def _when(self, stamp: float, now: float) -> dict[str, Any]:
        """ISO UTC, the site's wall clock, "N s ago" and unix seconds of ``stamp``."""
        return {
            "time": iso(stamp),
            "local": local_clock(stamp, self.zone),
            "ago": ago(stamp, now),
            "t": round(stamp, 3),
        }

    def _said(self, stamp: float) -> str:
        """``15:00 CET (2026-11-24T14:00:00.000Z)``: for answer sentences."""
        return f"{clock_time(stamp, self.zone)} ({iso(stamp)})"

    def _flush(self) -> None:
        """Answers include what arrived up to now, not only what the flusher wrote."""
        self.indexer.flush()

    # -- tools -------------------------------------------------------------------------------
    def what_happened(
        self,
        start: str = "-10m",
        end: str = "now",
        kinds: Sequence[str] | None = None,
        place: str | None = None,
        max_items: int = 50,
    ) -> dict[str, Any]:
        now = self._clock()
        begin, finish = self._range(start, end, now)
        where = self._place(place)
        wanted = tuple(kinds) if kinds else DIGEST_KINDS
        unknown = [k for k in wanted if k not in DIGEST_KINDS]
        if unknown:
            raise EpisodicError(
                "invalid_argument",
                f"unknown kinds {unknown}; use any of {', '.join(DIGEST_KINDS)}",
            )
        if not 1 <= max_items <= 500:
            raise EpisodicError("invalid_argument", "max_items must be between 1 and 500")
        self._flush()
        # Only the newest max_items of the window survive, so each kind reads at most
        # max_items + 1 rows (the extra one tells "truncated") and only the kept rows are
        # turned into answer items.
        limit = max_items + 1
        rows: list[tuple[float, Sighting | Note | Visit]] = []
        if "sightings" in wanted:
            found = self.store.sightings_by_start(begin, finish, place=where, limit=limit)
            rows.extend((s.first_seen, s) for s in found)
        note_kinds = [k for group in wanted for k in _NOTE_GROUPS.get(group, ())]
        if note_kinds:
            notes = self.store.notes(
                begin, finish, kinds=note_kinds, place=where, limit=limit, newest_first=True
            )
            rows.extend((n.t, n) for n in notes)
        if "places" in wanted:
            rows.extend(
                (v.arrived, v) for v in self.store.visits(begin, finish, place=where, limit=limit)
            )
        rows.sort(key=lambda row: row[0])
        truncated = len(rows) > max_items
        items = [self._digest_item(row, now) for _, row in rows[-max_items:]]
        window = f"between {iso(begin)} and {iso(finish)}"
        summary = f"{len(items)} events {window}" if items else f"Nothing was recorded {window}."
        return {
            "start": self._when(begin, now),
            "end": self._when(finish, now),
            "place": where,
            "items": items,
            "count": len(items),
            "truncated": truncated,
            "summary": summary,
        }

    def _sighting_item(self, s: Sighting, now: float) -> dict[str, Any]:
        at = f" at {s.place}" if s.place else ""
        return {
            **self._when(s.first_seen, now),
            "kind": "sighting",
            "id": s.id,
            "label": s.label,
            "skill": s.skill,
            "place": s.place,
            "until": iso(s.last_seen),
            "text": f"saw {s.label}{at} for {duration(s.last_seen - s.first_seen)}",
        }

    def _note_item(self, n: Note, now: float) -> dict[str, Any]:
        return {
            **self._when(n.t, now),
            "kind": n.kind,
            "id": n.id,
            "text": n.text,
            "place": n.place,
            "mission_id": n.mission_id,
        }

    def _digest_item(self, row: Sighting | Note | Visit, now: float) -> dict[str, Any]:
        if isinstance(row, Sighting):
            return self._sighting_item(row, now)
        if isinstance(row, Note):
            return self._note_item(row, now)
        return {
            **self._when(row.arrived, now),
            "kind": "visit",
            "id": row.id,
            "place": row.place,
            "until": iso(row.departed),
            "text": f"was at {row.place} for {duration(row.departed - row.arrived)}",
        }

    def last_seen(
        self, query: str, before: str = "now", place: str | None = None, n: int = 3
    ) -> dict[str, Any]:
        now = self._clock()
        until = self._time("before", before, now)
        where = self._place(place)
        if not words(query):
            raise EpisodicError("invalid_argument", "query must name what to look for")
        if not 1 <= n <= 50:
            raise EpisodicError("invalid_argument", "n must be between 1 and 50")
        self._flush()
        known = self.store.labels()
        labels = matching_labels(known, query)
        read_as = None
        if not labels:  # a typo ("scisors"): the one label word close to it, said back
            read_as = corrected_query(known, query)
            labels = matching_labels(known, read_as) if read_as else []
            read_as = read_as if labels else None
        found = self.store.sightings(
            EPOCH_START, until, labels=labels, place=where, limit=n, newest_first=True
        )
        results = [self._sighting_answer(s, until, now) for s in found]
        if not results:
            at = f" at {where}" if where else ""
            answer = f"I have no record of seeing {query}{at} before {self._said(until)}."
        else:
            top = results[0]
            at = f" at {top['place']}" if top["place"] else ""
            answer = (
                f"I last saw {top['label']}{at} {top['last_seen']['ago']} "
                f"({self._said(top['last_seen']['t'])})."
            )
            if top["absent_since"]:
                answer += f" When I looked again {top['absent_since']['ago']} it was gone."
            if read_as:
                answer += f" (I read {query!r} as {top['label']}.)"
        return {
            "query": query,
            "read_as": read_as,
            "before": self._when(until, now),
            "place": where,
            "found": bool(results),
            "results": results,
            "answer": answer,
        }

    def _sighting_answer(self, s: Sighting, until: float, now: float) -> dict[str, Any]:
        last = min(s.last_seen, until)
        absent = s.absent_since if s.absent_since is not None and s.absent_since <= until else None
        return {
            "id": s.id,
            "label": s.label,
            "skill": s.skill,
            "first_seen": self._when(s.first_seen, now),
            "last_seen": self._when(last, now),
            "seen_for_s": round(last - s.first_seen, 3),
            "seen_for": duration(last - s.first_seen),
            "count": s.count,
            "best_score": s.best_score,
            "box": s.box,
            "place": s.place,
            "robot_pose": (
                {"x": s.x, "y": s.y, "yaw": s.yaw, "map": s.map} if s.x is not None else None
            ),
            "absent_since": self._when(absent, now) if absent is not None else None,
        }

    def search_memory(
        self,
        query: str,
        start: str | None = None,
        end: str | None = None,
        place: str | None = None,
        k: int = 10,
    ) -> dict[str, Any]:
        now = self._clock()
        begin, finish = self._range(start, end, now)
        where = self._place(place)
        terms = words(query)
        if not terms:
            raise EpisodicError("invalid_argument", "query has no words to search for")
        if not 1 <= k <= 100:
            raise EpisodicError("invalid_argument", "k must be between 1 and 100")
        self._flush()
        hits: list[dict[str, Any]] = []
        notes = self.store.search_notes(terms, begin, finish, place=where, k=k)
        best = max((hit.score for hit in notes), default=0.0)
        for rank, hit in enumerate(notes):
            # Scaled into (0, 1]; ties of a zero-IDF term keep the store's order.
            score = hit.score / best if best > 0 else 1.0 / (1 + rank)
            hits.append({**self._note_item(hit.note, now), "score": round(score, 4)})
        labels = {
            label: score
            for label in self.store.labels()
            if (score := label_matches(label, terms)) > 0
        }
        for s in self.store.sightings(
            begin, finish, labels=list(labels), place=where, limit=k, newest_first=True
        ):
            hits.append({**self._sighting_item(s, now), "score": round(labels[s.label], 4)})
        hits.sort(key=lambda hit: (-hit["score"], -hit["t"]))
        return {
            "query": query,
            "start": self._when(begin, now),
            "end": self._when(finish, now),
            "place": where,
            "results": hits[:k],
            "found": bool(hits),
        }

    def pose_at(self, time: str) -> dict[str, Any]:
        now = self._clock()
        at = self._time("time", time, now)
        if at > now + 1.0:
            raise EpisodicError("invalid_time", f"time: {iso(at)} is in the future")
        self._flush()
        before, after = self.store.pose_near(at)
        candidates = [p for p in (before, after) if p is not None and abs(p.t - at) <= POSE_NEAR_S]
        mission = self._mission_at(at, now)
        if not candidates:
            return {
                **self._when(at, now),
                "found": False,
                "mission": mission,
                "answer": f"No pose was recorded within {int(POSE_NEAR_S)} s of {self._said(at)}.",
            }
        pose = min(candidates, key=lambda p: abs(p.t - at))
        place = pose.place or "no named place"
        return {
            **self._when(at, now),
            "found": True,
            "pose": {"x": pose.x, "y": pose.y, "yaw": pose.yaw, "map": pose.map},
            "place": pose.place,
            "sample": {**self._when(pose.t, now), "id": f"p-{pose.id}"},
            "mission": mission,
            "answer": f"At {self._said(at)} I was at {place} (x {pose.x:.2f}, y {pose.y:.2f}).",
        }

    def _mission_at(self, at: float, now: float) -> dict[str, Any] | None:
        events = self.store.notes(
            EPOCH_START, at, kinds=list(MISSION_KINDS), limit=1, newest_first=True
        )
        if not events or events[0].kind != "mission_started":
            return None
        event = events[0]
        return {
            "mission_id": event.mission_id,
            "text": event.text,
            "started": self._when(event.t, now),
        }

    def known_labels(self) -> dict[str, Any]:
        """Every label this robot has a sighting of: the names of the things it can be asked
        about (the brain's on-board recognizer listens for them)."""
        self._flush()
        labels = sorted(self.store.labels())
        return {"labels": labels, "count": len(labels)}

    def memory_status(self) -> dict[str, Any]:
        now = self._clock()
        self._flush()
        stats = self.store.stats()
        bags = self.bags.bags() if self.bags else []
        bag_bytes = sum(b.size_bytes for b in bags)
        oldest = [k.oldest for k in stats.kinds.values() if k.oldest is not None]
        return {
            "robot_id": self.store.robot_id,
            "map": self.places.map,
            "now": self._when(now, now),
            "oldest_record": self._when(min(oldest), now) if oldest else None,
            "index": {
                kind: {
                    "rows": k.rows,
                    "oldest": iso(k.oldest) if k.oldest is not None else None,
                    "newest": iso(k.newest) if k.newest is not None else None,
                }
                for kind, k in stats.kinds.items()
            },
            "size_bytes": {"index": stats.size_bytes, "recordings": bag_bytes},
            "recordings": {
                "enabled": self.bags is not None,
                "bags": len(bags),
                "oldest": iso(bags[0].start) if bags else None,
                "messages": sum(b.messages for b in bags),
                "messages_on_disk": sum(b.on_disk for b in bags),
            },
            "retention": {
                "recordings_h": self.retention.bags_h,
                "index_d": self.retention.index_d,
                "max_mb": self.retention.max_mb,
                "horizon": {
                    "recordings": iso(now - self.retention.bags_h * 3600),
                    "index": iso(now - self.retention.index_d * 86400),
                },
                "flush_s": self.retention.flush_s,
            },
            "last_write": {
                stream: self._when(t, now) for stream, t in sorted(self.indexer.last_write.items())
            },
            "recording_gaps": self._gaps(now),
            "forget_audit": stats.audit,
        }

    def _gaps(
        self, now: float, window_s: float = 86400.0, min_gap_s: float = 60.0
    ) -> list[dict[str, Any]]:
        gaps = []
        previous: float | None = None
        for pose in self.store.poses(now - window_s, now, limit=100_000):
            if previous is not None and pose.t - previous >= min_gap_s:
                gaps.append(
                    {"from": iso(previous), "to": iso(pose.t), "seconds": round(pose.t - previous)}
                )
            previous = pose.t
        return gaps[-20:]

    def forget(
        self,
        start: str,
        end: str,
        label: str | None = None,
        place: str | None = None,
        dry_run: bool = True,
        approved_by: str | None = None,
    ) -> dict[str, Any]:
        """``approved_by``: the operator who approved the deletion (kept in the audit)."""
        now = self._clock()
        begin, finish = self._range(start, end, now)
        where = self._place(place)
        self._flush()
        if label is not None and not words(label):
            raise EpisodicError("invalid_argument", "label must name something")
        rows = self._forget_rows(begin, finish, label, where)
        recordings = self._forget_recordings(begin, finish, rows.sightings, label, where, dry_run)
        request = {
            "start": iso(begin), "end": iso(finish), "label": label, "place": where,
            "dry_run": dry_run,
        }  # fmt: skip
        if dry_run:
            return {
                **request, "would_delete": {**rows.counts(), "recorded_messages": recordings},
                "answer": "Preview only: call forget again with dry_run=false to delete.",
            }  # fmt: skip
        self.indexer.forget_open({s.id for s in rows.sightings}, {v.id for v in rows.visits})
        deleted = self.store.delete(
            [s.id for s in rows.sightings],
            [n.id for n in rows.notes],
            [p.id for p in rows.poses if p.id is not None],
            [v.id for v in rows.visits],
        )
        result = {
            "sightings": deleted.sightings, "notes": deleted.notes, "poses": deleted.poses,
            "visits": deleted.visits, "recorded_messages": recordings,
        }  # fmt: skip
        self.store.record_audit(now, {**request, "approved_by": approved_by}, result)
        logger.info("episodic_forgot", robot_id=self.store.robot_id, **request, **result)
        return {**request, "deleted": result, "answer": "Deleted and audited."}

    def _forget_rows(
        self, begin: float, finish: float, label: str | None, where: str | None
    ) -> _ForgetRows:
        """What a forget removes from the index: with a label, its sightings and the notes
        that name it; without, every row in the window (at ``where`` if given)."""
        many = 10_000_000
        if label is not None:
            labels = matching_labels(self.store.labels(), label)
            hits = self.store.search_notes(words(label), begin, finish, place=where, k=many)
            return _ForgetRows(
                self.store.sightings(begin, finish, labels=labels, place=where, limit=many),
                [hit.note for hit in hits],
            )
        return _ForgetRows(
            self.store.sightings(begin, finish, place=where, limit=many),
            self.store.notes(begin, finish, place=where, limit=many),
            [p for p in self.store.poses(begin, finish, limit=many) if where in (None, p.place)],
            self.store.visits(begin, finish, place=where, limit=many),
        )

    def _forget_recordings(
        self,
        begin: float,
        finish: float,
        sightings: Sequence[Sighting],
        label: str | None,
        where: str | None,
        dry_run: bool,
    ) -> int:
        if self.bags is None:
            return 0
        if label is None and where is None:
            return self.bags.forget(begin, finish, lambda *_: True, dry_run=dry_run)
        from robot_mcp_episodic.recording_filter import sighting_selector

        # Recordings are logged at receive time, the index at the image stamp: a margin
        # covers the transport delay (only frames that show the label are removed).
        margin = RECEIVE_MARGIN_S
        windows = [
            (s.skill, s.label, max(begin, s.first_seen) - margin, min(finish, s.last_seen) + margin)
            for s in sightings
        ]
        if not windows:
            return 0
        selector = sighting_selector(windows)
        low = min(w[2] for w in windows)
        high = max(w[3] for w in windows)
        return self.bags.forget(low, high, selector, dry_run=dry_run)

    def record_note(self, kind: str, text: str, mission_id: str | None = None) -> dict[str, Any]:
        if kind not in NOTE_KINDS:
            raise EpisodicError(
                "invalid_argument", f"kind must be one of {', '.join(NOTE_KINDS)}; got {kind!r}"
            )
        if not text.strip():
            raise EpisodicError("invalid_argument", "text is empty")
        if len(text) > 8000:
            raise EpisodicError("invalid_argument", "text is longer than 8000 characters")
        note = self.indexer.note(kind, text.strip(), mission_id)
        now = self._clock()
        return {"id": note.id, **self._when(note.t, now), "kind": kind, "place": note.place}
