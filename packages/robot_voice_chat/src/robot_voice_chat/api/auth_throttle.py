"""Login throttling: a per-address failure budget counted *before* the slow password check, and
a cap on how many argon2 checks run at once (each needs ~64 MiB and ~50 ms of CPU)."""

from __future__ import annotations

import asyncio
import time
from collections import deque
from collections.abc import AsyncIterator, Callable
from contextlib import asynccontextmanager


class LoginThrottle:
    """Counts login attempts per client address in a sliding window (memory only).

    An attempt is counted when it is *reserved*, before the password is checked, so parallel
    requests cannot all pass the check while the first ones are still hashing; a success
    forgets the address's count."""

    def __init__(
        self, max_failures: int, window_s: float, clock: Callable[[], float] = time.monotonic
    ) -> None:
        self.max_failures = max_failures
        self.window_s = window_s
        self._clock = clock
        self._failures: dict[str, deque[float]] = {}

    def retry_after(self, address: str) -> float:
        """Seconds until ``address`` may try again (0 when it may try now)."""
        recent = self._recent(address)
        if len(recent) < self.max_failures:
            return 0.0
        return max(0.0, recent[0] + self.window_s - self._clock())

    def reserve(self, address: str) -> float:
        """Count one attempt now; 0 when it may go ahead, else the seconds to wait (and the
        attempt is not counted). Synchronous: no other request runs between check and count."""
        wait = self.retry_after(address)
        if wait == 0:
            self.failed(address)
        return wait

    def failed(self, address: str) -> None:
        self._recent(address).append(self._clock())

    def succeeded(self, address: str) -> None:
        self._failures.pop(address, None)

    def _recent(self, address: str) -> deque[float]:
        now = self._clock()
        recent = self._failures.setdefault(address, deque())
        while recent and recent[0] <= now - self.window_s:
            recent.popleft()
        if len(self._failures) > 10_000:  # bound memory under a spray of addresses
            for key in [k for k, v in self._failures.items() if not v and k != address]:
                del self._failures[key]
        return recent


class PasswordChecksBusyError(Exception):
    """Every password-check slot and every waiting place is taken."""


class PasswordCheckSlots:
    """At most ``running`` password checks at once and ``waiting`` queued behind them; more
    are refused at once, so a burst of logins (from any number of addresses) costs bounded
    memory and CPU."""

    def __init__(self, running: int, waiting: int) -> None:
        self.running = running
        self.waiting = waiting
        self._semaphore = asyncio.Semaphore(running)
        self._admitted = 0

    @property
    def admitted(self) -> int:
        """Checks running or waiting now."""
        return self._admitted

    @asynccontextmanager
    async def slot(self) -> AsyncIterator[None]:
        if self._admitted >= self.running + self.waiting:
            raise PasswordChecksBusyError
        self._admitted += 1
        try:
            async with self._semaphore:
                yield
        finally:
            self._admitted -= 1
