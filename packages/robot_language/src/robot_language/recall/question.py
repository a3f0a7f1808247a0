"""The ``Recall`` type: a question about the past as the one episodic tool call answering it."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Literal

WHAT_HAPPENED = "episodic.what_happened"
LAST_SEEN = "episodic.last_seen"
POSE_AT = "episodic.pose_at"
RecallKind = Literal["seen", "digest", "away", "last_seen", "pose_at", "visits"]


@dataclass(frozen=True)
class Recall:
    """A question about the past as one episodic call; ``said``: the time as the robot restates it
    ("around 30 s ago", "in the last 10 minutes"), ``obj``/``place``: what and where was asked."""

    kind: RecallKind
    tool: str
    arguments: dict[str, Any] = field(default_factory=dict)
    said: str = ""
    obj: str | None = None
    place: str | None = None
    since_turn: bool = False  # start at the person's previous turn, when it is known
    first: bool = False  # last_seen: the earliest sighting on record is asked for, not the last
    around: bool = False  # a window around a clock time: the answer says the server's window
    offer: bool = False  # "where is X": the answer offers to go and look (asks, never moves)

    def code(self) -> str:
        """The phrasing sets' label: answer:history | answer:last_seen | answer:pose_at."""
        if self.tool == LAST_SEEN:
            return "last_seen"
        if self.tool == POSE_AT:
            return "pose_at"
        return "history"
