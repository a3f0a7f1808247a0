"""The episodic store port: what the index keeps and how it is read, whatever the database.

Three kinds of rows, each carrying ``robot_id`` and ``map``:

- :class:`Sighting` — one *interval* in which a skill kept seeing a label (first and last seen,
  how often, the best score and its box, the robot's pose and named place when it first saw
  it, and ``absent_since`` once the robot looked at that place again and did not see it);
- :class:`PoseSample` — the downsampled pose track;
- :class:`Note` — scene descriptions, mission events, user turns, what the robot said;
- :class:`Visit` — a stay at one named place (arrived, departed).

Times are unix seconds (float). Every read is scoped to the store's ``robot_id``. Adapters:
:mod:`.sqlite` (embedded, WAL) and :mod:`.postgres` (a fleet's server); both pass the same
contract suite.
"""

from __future__ import annotations

import abc
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

Kind = Literal["sightings", "poses", "notes", "visits"]
KINDS: tuple[Kind, ...] = ("sightings", "poses", "notes", "visits")


class StoreError(RuntimeError):
    """The database cannot be opened, read or written."""


@dataclass
class Sighting:
    id: str
    robot_id: str
    map: str
    skill: str
    label: str
    first_seen: float
    last_seen: float
    count: int = 1
    best_score: float = 0.0
    box: dict[str, int] | None = None
    x: float | None = None
    y: float | None = None
    yaw: float | None = None
    place: str | None = None
    absent_since: float | None = None


@dataclass(frozen=True)
class PoseSample:
    robot_id: str
    map: str
    t: float
    x: float
    y: float
    yaw: float
    place: str | None = None
    id: int | None = None


@dataclass(frozen=True)
class Note:
    id: str
    robot_id: str
    map: str
    t: float
    kind: str
    text: str
    mission_id: str | None = None
    place: str | None = None


@dataclass
class Visit:
    """A stay at one named place: from the first to the last pose there (kept by the
    indexer as the robot moves, so "places visited" never scans the pose track)."""

    id: str
    robot_id: str
    map: str
    place: str
    arrived: float
    departed: float


@dataclass(frozen=True)
class ScoredNote:
    note: Note
    score: float


@dataclass(frozen=True)
class Deleted:
    sightings: int = 0
    poses: int = 0
    notes: int = 0
    visits: int = 0

    def total(self) -> int:
        return self.sightings + self.poses + self.notes + self.visits


@dataclass(frozen=True)
class KindStats:
    rows: int
    oldest: float | None
    newest: float | None


@dataclass(frozen=True)
class StoreStats:
    kinds: dict[str, KindStats]
    size_bytes: int
    audit: list[dict[str, Any]] = field(default_factory=list)


class EpisodicStore(abc.ABC):
    """One robot's view of the episodic index (``robot_id`` fixed at construction)."""

    robot_id: str

    # -- writes (called by the ingest flusher, in batches) -----------------------------------
    @abc.abstractmethod
    def save_sightings(self, sightings: Sequence[Sighting]) -> None:
        """Insert or update by id (an interval grows while it is open)."""

    @abc.abstractmethod
    def save_poses(self, poses: Sequence[PoseSample]) -> None: ...

    @abc.abstractmethod
    def save_notes(self, notes: Sequence[Note]) -> None: ...

    @abc.abstractmethod
    def save_visits(self, visits: Sequence[Visit]) -> None:
        """Insert or update by id (a stay grows while the robot is there)."""

    # -- reads -------------------------------------------------------------------------------
    @abc.abstractmethod
    def labels(self) -> list[str]:
        """Every label this robot has a sighting of."""

    @abc.abstractmethod
    def latest_sighting(self, skill: str, label: str) -> Sighting | None:
        """The newest interval of ``label`` seen by ``skill`` (to continue it after a restart)."""

    @abc.abstractmethod
    def sightings(
        self,
        start: float,
        end: float,
        *,
        labels: Sequence[str] | None = None,
        place: str | None = None,
        limit: int = 100,
        newest_first: bool = False,
    ) -> list[Sighting]:
        """Intervals that overlap ``[start, end]`` (``labels``/``place`` filter first)."""

    @abc.abstractmethod
    def sightings_by_start(
        self, start: float, end: float, *, place: str | None = None, limit: int = 50
    ) -> list[Sighting]:
        """The ``limit`` intervals overlapping ``[start, end]`` that began last, the latest
        start first: what a chronological digest of the window ends with. Reads at most
        ``limit`` rows whatever the window and the history (an index on the start)."""

    @abc.abstractmethod
    def notes(
        self,
        start: float,
        end: float,
        *,
        kinds: Sequence[str] | None = None,
        place: str | None = None,
        limit: int = 100,
        newest_first: bool = False,
    ) -> list[Note]: ...

    @abc.abstractmethod
    def search_notes(
        self,
        terms: Sequence[str],
        start: float,
        end: float,
        *,
        place: str | None = None,
        k: int = 10,
    ) -> list[ScoredNote]:
        """Full text (any of ``terms``) over notes in ``[start, end]``, best first."""

    @abc.abstractmethod
    def poses(self, start: float, end: float, *, limit: int = 10_000) -> list[PoseSample]:
        """Pose samples in ``[start, end]``, oldest first."""

    @abc.abstractmethod
    def visits(
        self, start: float, end: float, *, place: str | None = None, limit: int = 1000
    ) -> list[Visit]:
        """The ``limit`` stays (at ``place``, if given) overlapping ``[start, end]`` that began
        last, oldest first."""

    @abc.abstractmethod
    def pose_near(self, t: float) -> tuple[PoseSample | None, PoseSample | None]:
        """The newest sample at or before ``t`` and the oldest after it."""

    # -- deletion, retention, status ---------------------------------------------------------
    @abc.abstractmethod
    def delete(
        self,
        sighting_ids: Sequence[str],
        note_ids: Sequence[str],
        pose_ids: Sequence[int],
        visit_ids: Sequence[str] = (),
    ) -> Deleted: ...

    @abc.abstractmethod
    def delete_before(self, kind: Kind, before: float) -> int:
        """Retention: drop ``kind`` rows that ended before ``before``; returns how many."""

    @abc.abstractmethod
    def record_audit(self, t: float, request: dict[str, Any], result: dict[str, Any]) -> None:
        """Append one forget to the audit log (never deleted by retention or forget)."""

    @abc.abstractmethod
    def stats(self) -> StoreStats: ...

    def compact(self) -> None:  # noqa: B027 - optional: not every database can
        """Give the space of deleted rows back to the file system (if the database can)."""

    @abc.abstractmethod
    def close(self) -> None: ...
