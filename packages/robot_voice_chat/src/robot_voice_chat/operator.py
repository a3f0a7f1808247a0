"""Who is acting: the logged-in operator of the current request or socket event.

A context variable, so it follows the request into the tasks it starts (a mission run started
from an operator's message keeps that operator). ``None`` when auth is off or for machine
callers (the signed event ingress).
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar

import structlog

current_operator: ContextVar[str | None] = ContextVar("current_operator", default=None)


@contextmanager
def acting_operator(name: str | None) -> Iterator[None]:
    """Bind ``name`` as the acting operator (context variable + log field) for a block."""
    token = current_operator.set(name)
    try:
        if name is None:
            yield
        else:
            with structlog.contextvars.bound_contextvars(operator=name):
                yield
    finally:
        current_operator.reset(token)


def operator_fields() -> dict[str, str]:
    """``{"operator": name}`` when an operator is acting, else ``{}`` (for trace records)."""
    name = current_operator.get()
    return {"operator": name} if name is not None else {}
