"""Deadline-bound waits: tests never sleep without one."""

from __future__ import annotations

import asyncio
import time
from collections.abc import Awaitable, Callable
from typing import Any, TypeVar, overload

T = TypeVar("T")


def wait_until(
    predicate: Callable[[], T], timeout_s: float, what: str = "condition", interval_s: float = 0.02
) -> T:
    """Poll ``predicate`` until it returns something truthy; raise TimeoutError at the deadline."""
    deadline = time.monotonic() + timeout_s
    while True:
        result = predicate()
        if result:
            return result
        if time.monotonic() >= deadline:
            raise TimeoutError(f"timed out after {timeout_s:.1f}s waiting for {what}")
        time.sleep(interval_s)


@overload
async def async_wait_until(
    predicate: Callable[[], Awaitable[T]],
    timeout_s: float,
    what: str = ...,
    interval_s: float = ...,
) -> T: ...


@overload
async def async_wait_until(
    predicate: Callable[[], T],
    timeout_s: float,
    what: str = ...,
    interval_s: float = ...,
) -> T: ...


async def async_wait_until(
    predicate: Callable[[], Any],
    timeout_s: float,
    what: str = "condition",
    interval_s: float = 0.02,
) -> Any:
    """Async twin of :func:`wait_until`; the predicate may be sync or async."""
    deadline = time.monotonic() + timeout_s
    while True:
        result = predicate()
        if asyncio.iscoroutine(result) or isinstance(result, asyncio.Future):
            result = await result
        if result:
            return result
        if time.monotonic() >= deadline:
            raise TimeoutError(f"timed out after {timeout_s:.1f}s waiting for {what}")
        await asyncio.sleep(interval_s)
