"""EventPoster: signed, durable, per-task-ordered delivery of TaskEvents to the brain.

Guarantees (see the README): at-least-once (the same ``event_id`` and body bytes on every
retry), strictly in ``seq`` order within a task (the next event of a task is posted only
after the previous one was accepted or dead-lettered), durable before :meth:`EventPoster.emit`
returns (a SQLite outbox that survives receiver outages and the poster's own restarts).

Nothing is dropped silently: an authentication or configuration refusal (401, 403, 404, 405)
keeps the event in the outbox, retried with backoff and logged as an error
(``event_refused``), and :meth:`EventPoster.health` reports it; a malformed-event refusal
(any other 4xx) moves the event to the outbox's dead-letter table (``event_dead_lettered``).
"""

from __future__ import annotations

import asyncio
import contextlib
import random
import time
from collections import deque
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from types import TracebackType
from typing import Any, Literal, TypeVar

import httpx
import structlog

from robot_mcp_kit.correlation import current_mission_id
from robot_mcp_kit.models import EventType, TaskEvent
from robot_mcp_kit.outbox import Appended, DeadLetter, SqliteOutbox, StoredEvent
from robot_mcp_kit.retry import backoff_delay, parse_retry_after
from robot_mcp_kit.signing import _secret_bytes, signed_headers

logger = structlog.get_logger("robot_mcp_kit.poster")

T = TypeVar("T")
_State = Literal["new", "started", "closing", "closed"]
REFUSED_STATUSES = frozenset({401, 403, 404, 405})
"""The receiver refuses us, not the event (secret mismatch, clock skew, wrong URL): keep the
event and retry — an operator fixes the configuration and delivery resumes."""
RETRY_STATUSES = frozenset({408, 425, 429})


class PosterClosedError(RuntimeError):
    """emit() on a poster that is not started or already closing."""


@dataclass(frozen=True)
class _Outcome:
    kind: Literal["delivered", "dead", "refused", "retry"]
    reason: str
    status: int | None = None
    retry_after_s: float | None = None


def _with_seq(draft: TaskEvent, seq: int) -> TaskEvent:
    return draft.model_copy(update={"seq": seq})


def _ms(since: float) -> float:
    return round((time.monotonic() - since) * 1000, 1)


class EventPoster:
    """Posts TaskEvents to ``url`` (the brain's ``/api/agent/events``); one per process."""

    def __init__(
        self,
        url: str,
        server: str,
        secret: str | bytes,
        outbox_path: str | Path,
        *,
        max_outbox: int = 10_000,
        request_timeout_s: float = 5.0,
        backoff_initial_s: float = 0.2,
        backoff_max_s: float = 10.0,
        client: httpx.AsyncClient | None = None,
        max_concurrency: int = 8,
        retry_after_max_s: float = 300.0,
        counter_retention_s: float = 30 * 86_400.0,
    ) -> None:
        parsed = httpx.URL(url)
        if parsed.scheme not in ("http", "https") or not parsed.host:
            raise ValueError(f"event url must be an absolute http(s) URL, got {url!r}")
        if not server:
            raise ValueError("server name must not be empty")
        if max_outbox < 1 or max_concurrency < 1:
            raise ValueError("max_outbox and max_concurrency must be at least 1")
        if request_timeout_s <= 0 or backoff_initial_s <= 0 or backoff_max_s < backoff_initial_s:
            raise ValueError("timeouts and backoff must be positive, with max >= initial")
        self._url = url
        self._server = server
        self._secret = _secret_bytes(secret)
        self._outbox_path = Path(outbox_path)
        self._max_outbox = max_outbox
        self._request_timeout_s = request_timeout_s
        self._backoff_initial_s = backoff_initial_s
        self._backoff_max_s = backoff_max_s
        self._retry_after_max_s = retry_after_max_s
        self._counter_retention_s = counter_retention_s
        self._max_concurrency = max_concurrency
        self._client = client
        self._owns_client = client is None
        self._rng = random.Random()

        self._outbox = SqliteOutbox(self._outbox_path)
        self._db_thread: ThreadPoolExecutor | None = None
        self._state: _State = "new"
        self._queues: dict[str, deque[StoredEvent]] = {}
        self._queued_rows: set[int] = set()
        self._in_flight: set[int] = set()
        self._lanes: dict[str, asyncio.Task[None]] = {}
        self._emit_lock = asyncio.Lock()
        self._drained = asyncio.Event()
        self._drained.set()
        self._slots = asyncio.Semaphore(max_concurrency)
        self._stats = {
            "emitted": 0,
            "delivered": 0,
            "rejected": 0,
            "refused": 0,
            "dropped": 0,
            "retries": 0,
        }
        self._refusal: dict[str, Any] | None = None
        self._dead_letters = 0

    # -- life cycle ----------------------------------------------------------------------

    async def __aenter__(self) -> EventPoster:
        await self.start()
        return self

    async def __aexit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        await self.close()

    async def start(self) -> None:
        """Open the outbox and resume delivering what a previous process life left."""
        if self._state != "new":
            raise PosterClosedError(f"start() on a poster that is {self._state}")
        started = time.monotonic()
        self._db_thread = ThreadPoolExecutor(max_workers=1, thread_name_prefix="event-outbox")
        try:
            pending = await self._db(self._outbox.open, self._counter_retention_s)
        except BaseException:
            self._db_thread.shutdown(wait=False)
            self._db_thread = None
            raise
        if self._client is None:
            self._client = httpx.AsyncClient(
                timeout=self._request_timeout_s,
                limits=httpx.Limits(max_connections=self._max_concurrency),
            )
        self._dead_letters = await self._db(self._outbox.dead_letter_count)
        self._state = "started"
        for stored in pending:
            self._enqueue(stored)
        logger.info(
            "event_outbox_opened",
            path=str(self._outbox_path),
            resumed=len(pending),
            tasks=len(self._queues),
            duration_ms=_ms(started),
        )

    async def close(self, flush_timeout_s: float = 5.0) -> None:
        """Stop accepting events, deliver what can be delivered within ``flush_timeout_s``;
        everything else stays in the outbox for the next start."""
        if self._state in ("closing", "closed"):
            return
        if self._state == "new":
            self._state = "closed"
            return
        started = time.monotonic()
        self._state = "closing"
        async with self._emit_lock:  # let emits that already began finish storing
            pass
        with contextlib.suppress(TimeoutError):
            async with asyncio.timeout(max(0.0, flush_timeout_s)):
                await self._drained.wait()
        lanes = list(self._lanes.values())
        for lane in lanes:
            lane.cancel()
        await asyncio.gather(*lanes, return_exceptions=True)
        await self._db(self._outbox.close)
        assert self._db_thread is not None
        self._db_thread.shutdown(wait=True)
        self._db_thread = None
        if self._owns_client and self._client is not None:
            await self._client.aclose()
            self._client = None
        self._state = "closed"
        logger.info(
            "event_poster_closed",
            persisted=len(self._queued_rows),
            **self._stats,
            duration_ms=_ms(started),
        )

    # -- the public surface --------------------------------------------------------------

    async def emit(
        self,
        task_id: str,
        tool: str,
        type: EventType,
        payload: dict[str, Any] | None = None,
    ) -> TaskEvent:
        """Queue one event for delivery: assigns the task's next ``seq`` and an ``event_id``;
        the event is on disk when this returns.

        Raises ``pydantic.ValidationError`` for a malformed event, ``OutboxFullError`` when the
        outbox is full of events that must not be dropped, ``PosterClosedError`` when the
        poster is not running.
        """
        self._ensure_open()
        payload = dict(payload or {})
        mission_id = current_mission_id()  # the tool call that started this task, if any
        if mission_id is not None:
            payload.setdefault("mission_id", mission_id)
        draft = TaskEvent(
            task_id=task_id, server=self._server, tool=tool, type=type, seq=0, payload=payload
        )
        draft.model_dump_json()  # an unserialisable payload fails here, before any disk work
        # Shielded: once the event is being stored, a cancelled caller must not leave it on
        # disk but unknown to the delivery lanes.
        return await asyncio.shield(self._store(draft))

    def pending_count(self) -> int:
        """Events not yet delivered (still in the outbox)."""
        return len(self._queued_rows)

    def stats(self) -> dict[str, int]:
        """Counters since start: emitted, delivered, rejected (dead-lettered), refused (401 /
        403 / 404 / 405 answers, retried), dropped, retries; plus pending, dead letters and
        in_flight (posts under way now; such an event is never dropped for room)."""
        return {
            **self._stats,
            "pending": self.pending_count(),
            "dead_letters": self._dead_letters,
            "in_flight": len(self._in_flight),
        }

    def health(self) -> dict[str, Any]:
        """``status`` is ``"refused"`` while the receiver refuses us (events wait in the
        outbox; ``last_refusal`` says why), ``"ok"`` otherwise; with :meth:`stats`."""
        return {
            "status": "refused" if self._refusal is not None else "ok",
            "last_refusal": dict(self._refusal) if self._refusal is not None else None,
            "outbox": str(self._outbox_path),
            **self.stats(),
        }

    async def dead_letters(self, limit: int = 100) -> list[DeadLetter]:
        """The most recent dead-lettered events (newest first)."""
        return await self._db(self._outbox.dead_letters, limit)

    async def wait_drained(self, timeout_s: float) -> bool:
        """Wait until nothing is pending; False at the deadline."""
        try:
            async with asyncio.timeout(timeout_s):
                await self._drained.wait()
        except TimeoutError:
            return False
        return True

    # -- storing -------------------------------------------------------------------------

    def _ensure_open(self) -> None:
        if self._state != "started":
            raise PosterClosedError(f"the event poster is {self._state}; events are not accepted")

    async def _store(self, draft: TaskEvent) -> TaskEvent:
        async with self._emit_lock:
            self._ensure_open()
            appended: Appended = await self._db(
                self._outbox.append,
                partial(_with_seq, draft),
                draft.task_id,
                self._max_outbox,
                frozenset(self._in_flight),
            )
            for gone in appended.dropped:
                self._forget(gone)
                self._stats["dropped"] += 1
                logger.warning(
                    "event_dropped",
                    reason="outbox_full",
                    event_id=gone.event_id,
                    task_id=gone.task_id,
                    type=gone.type,
                    seq=gone.seq,
                    max_outbox=self._max_outbox,
                )
            self._stats["emitted"] += 1
            self._enqueue(appended.stored)
            return appended.event

    def _enqueue(self, stored: StoredEvent) -> None:
        self._queues.setdefault(stored.task_id, deque()).append(stored)
        self._queued_rows.add(stored.row_id)
        self._drained.clear()
        if stored.task_id not in self._lanes:
            self._lanes[stored.task_id] = asyncio.create_task(
                self._run_lane(stored.task_id), name=f"event-lane-{stored.task_id}"
            )

    def _forget(self, stored: StoredEvent) -> None:
        if stored.row_id not in self._queued_rows:
            return
        self._queued_rows.discard(stored.row_id)
        queue = self._queues.get(stored.task_id)
        if queue is not None:
            with contextlib.suppress(ValueError):
                queue.remove(stored)
        if not self._queued_rows:
            self._drained.set()

    # -- delivering ----------------------------------------------------------------------

    async def _run_lane(self, task_id: str) -> None:
        """Deliver one task's events strictly one after another, in seq order."""
        queue = self._queues[task_id]
        try:
            while queue:
                head = queue[0]
                try:
                    outcome = await self._deliver(head)
                    if outcome is not None:
                        if outcome.kind == "dead":
                            await self._db(
                                self._outbox.dead_letter,
                                head.row_id,
                                outcome.status,
                                outcome.reason,
                            )
                            self._dead_letters += 1
                        else:
                            await self._db(self._outbox.remove, head.row_id)
                        self._forget(head)
                except Exception:  # lane boundary: log, back off, keep the event
                    logger.exception("event_lane_error", task_id=task_id, event_id=head.event_id)
                    await asyncio.sleep(self._backoff_max_s)
        finally:
            self._lanes.pop(task_id, None)
            if not queue and self._queues.get(task_id) is queue:
                del self._queues[task_id]

    async def _deliver(self, head: StoredEvent) -> _Outcome | None:
        """Post ``head`` until it is accepted or dead-lettered (that outcome), or was dropped
        meanwhile (None)."""
        attempt = 0
        while head.row_id in self._queued_rows:
            started = time.monotonic()
            async with self._slots:
                self._in_flight.add(head.row_id)
                try:
                    outcome = await self._post_once(head)
                finally:
                    self._in_flight.discard(head.row_id)
            fields: dict[str, Any] = {
                "event_id": head.event_id,
                "task_id": head.task_id,
                "type": head.type,
                "seq": head.seq,
                "status": outcome.status,
                "attempt": attempt + 1,
                "duration_ms": _ms(started),
            }
            if outcome.kind == "delivered":
                self._stats["delivered"] += 1
                self._refusal = None
                logger.debug("event_delivered", **fields)
                return outcome
            if outcome.kind == "dead":
                self._stats["rejected"] += 1
                logger.error("event_dead_lettered", reason=outcome.reason, **fields)
                return outcome
            delay = backoff_delay(attempt, self._backoff_initial_s, self._backoff_max_s, self._rng)
            if outcome.retry_after_s is not None:
                delay = min(outcome.retry_after_s, self._retry_after_max_s)
            self._stats["retries"] += 1
            attempt += 1
            if outcome.kind == "refused":
                self._stats["refused"] += 1
                self._refusal = {
                    "status": outcome.status,
                    "reason": outcome.reason,
                    "at": time.time(),
                }
                logger.error(
                    "event_refused", reason=outcome.reason, delay_s=round(delay, 3), **fields
                )
            else:
                log = logger.info if attempt == 1 else logger.warning
                log("event_retry", reason=outcome.reason, delay_s=round(delay, 3), **fields)
            await asyncio.sleep(delay)
        return None

    async def _post_once(self, head: StoredEvent) -> _Outcome:
        assert self._client is not None
        headers = signed_headers(self._server, self._secret, head.body)
        headers["Content-Type"] = "application/json"
        try:
            response = await self._client.post(
                self._url, content=head.body, headers=headers, timeout=self._request_timeout_s
            )
        except httpx.TransportError as exc:
            return _Outcome("retry", f"{type(exc).__name__}: {exc}"[:200])
        status = response.status_code
        if 200 <= status < 300:
            return _Outcome("delivered", "accepted", status)
        if status in RETRY_STATUSES or status >= 500:
            retry_after = parse_retry_after(response.headers.get("Retry-After"))
            return _Outcome("retry", f"http_{status}", status, retry_after)
        if status in REFUSED_STATUSES:
            return _Outcome("refused", f"http_{status}: {response.text[:200]}", status)
        if 400 <= status < 500:
            return _Outcome("dead", f"http_{status}: {response.text[:200]}", status)
        return _Outcome("refused", f"unexpected http_{status}", status)

    # -- plumbing ------------------------------------------------------------------------

    async def _db(self, fn: Callable[..., T], *args: Any) -> T:
        if self._db_thread is None:
            raise PosterClosedError("the outbox is not open")
        loop = asyncio.get_running_loop()
        return await loop.run_in_executor(self._db_thread, partial(fn, *args))
