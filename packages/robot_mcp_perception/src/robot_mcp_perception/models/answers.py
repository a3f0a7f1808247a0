"""Who answered a run's grounder calls: the marker results carry (``grounder`` in ``extra``).

The engine opens :func:`recording` around a skill run (like the cloud meter of
:mod:`.metering`); every grounder call notes who answered — the pipeline for a plain grounder,
the chain (:mod:`.chain`) for itself, naming its primary or its fallback and why the fallback
answered. :func:`marks` turns a run's notes into the additive result fields:

- ``grounder``: the name of the grounder that answered (the fallback's when any call of the
  run was answered by it);
- ``grounder_fallback``: ``true`` when a fallback answered, ``false`` when a chain's primary
  did (absent without a chain);
- ``fallback_reason``: why the primary did not answer (``network``, ``server_error``,
  ``quota``, ``timeout``, ``budget``, ``auth`` or ``backoff`` while it is left alone after a
  failure).
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class Answer:
    grounder: str
    fallback: bool | None = None
    """True: a chain's fallback answered; False: a chain's primary; None: no chain."""
    reason: str | None = None
    """Why the fallback answered (the primary's failure, or ``backoff``)."""


_current: ContextVar[list[Answer] | None] = ContextVar("grounder_answers", default=None)


@contextmanager
def recording() -> Iterator[list[Answer]]:
    """Collect the answers noted inside this block (and tasks it starts)."""
    notes: list[Answer] = []
    token = _current.set(notes)
    try:
        yield notes
    finally:
        _current.reset(token)


def note(answer: Answer) -> None:
    """Record who answered one grounder call (no-op outside :func:`recording`)."""
    notes = _current.get()
    if notes is not None:
        notes.append(answer)


def marks(notes: list[Answer]) -> dict[str, Any]:
    """The result fields for a run's answers (empty when no grounder was called)."""
    if not notes:
        return {}
    answer = next((a for a in notes if a.fallback), notes[-1])
    found: dict[str, Any] = {"grounder": answer.grounder}
    if answer.fallback is not None:
        found["grounder_fallback"] = answer.fallback
    if answer.fallback and answer.reason:
        found["fallback_reason"] = answer.reason
    return found
