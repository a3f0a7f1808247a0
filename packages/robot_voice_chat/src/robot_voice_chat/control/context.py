"""Who is dispatching a tool call (a context variable set by the dispatcher, read by the guard).

The guard sits behind the tool port, whose ``call_tool`` knows nothing of missions: the
mission and step a call belongs to, and whether the caller may wait for a person's answer,
ride along in this context variable instead.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass


@dataclass(frozen=True)
class DispatchContext:
    mission_id: str | None = None
    step_id: str | None = None
    may_ask: bool = True  # False for prepared reactions and background reads: never wait
    caller: str | None = None  # who cannot ask, in words ("the UI's background read")
    # an operator's yes given up front for this very call (the Teach button arms the save of
    # the process it teaches): a ``confirm`` tool is sent without asking again
    approved_by: str | None = None


NO_CONTEXT = DispatchContext()
_current: ContextVar[DispatchContext | None] = ContextVar("current_dispatch", default=None)


def current_dispatch() -> DispatchContext:
    return _current.get() or NO_CONTEXT


@contextmanager
def dispatching(context: DispatchContext) -> Iterator[None]:
    token = _current.set(context)
    try:
        yield
    finally:
        _current.reset(token)
