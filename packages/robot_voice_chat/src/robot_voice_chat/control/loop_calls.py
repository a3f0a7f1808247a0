"""Calls across the supervisor's event loops (the brain's, the renewals' thread's): scheduled
thread-safely, and never onto a loop that has closed."""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import Callable
from typing import Any


def call_soon(
    loop: asyncio.AbstractEventLoop | None, callback: Callable[..., object], *args: Any
) -> None:
    """Run ``callback(*args)`` on ``loop`` from any thread (not once it closed or is closing)."""
    if loop is None or loop.is_closed():
        return
    with contextlib.suppress(RuntimeError):  # the loop is closing
        loop.call_soon_threadsafe(callback, *args)


def succeed(future: asyncio.Future[None]) -> None:
    if not future.done():
        future.set_result(None)


def fail(future: asyncio.Future[None], exc: BaseException) -> None:
    if not future.done():
        future.set_exception(exc)
