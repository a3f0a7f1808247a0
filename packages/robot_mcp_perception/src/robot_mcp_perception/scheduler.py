"""Pipelined async processing (spec 000 §2.1): N workers, ``max_in_flight``, drop-oldest.

Model work runs on an asyncio loop in a dedicated thread, so ROS callbacks never wait for a
model. ``submit`` is thread-safe and returns a ``concurrent.futures.Future`` that is resolved
on the loop thread (the node publishes from its done-callback; rclpy publish is thread-safe).

In flight = queued + running. When ``max_in_flight`` is reached the *oldest queued* job is
dropped (its future cancelled); if every in-flight job is already running the new job is
refused. Each job runs under ``asyncio.timeout(timeout_s)`` so a hung model frees its worker.
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import threading
import time
from collections import deque
from collections.abc import Awaitable, Callable
from dataclasses import dataclass, field
from typing import Any

import structlog

logger = structlog.get_logger("robot_mcp_perception.scheduler")

JobFactory = Callable[[], Awaitable[Any]]


class JobTimeoutError(TimeoutError):
    """A job exceeded the per-call timeout; its coroutine was cancelled."""


@dataclass
class _Job:
    key: str
    factory: JobFactory
    future: concurrent.futures.Future[Any]
    submitted_at: float = field(default_factory=time.monotonic)


@dataclass
class SchedulerStats:
    submitted: int = 0
    completed: int = 0
    failed: int = 0
    timed_out: int = 0
    dropped: int = 0
    refused: int = 0
    peak_in_flight: int = 0

    def as_dict(self) -> dict[str, int]:
        return dict(self.__dict__)


class Scheduler:
    def __init__(self, workers: int = 2, max_in_flight: int = 4, timeout_s: float = 10.0) -> None:
        if workers < 1 or max_in_flight < 1:
            raise ValueError("workers and max_in_flight must be at least 1")
        self.workers = workers
        self.max_in_flight = max_in_flight
        self.timeout_s = timeout_s
        self.stats = SchedulerStats()
        self._queue: deque[_Job] = deque()
        self._running = 0
        self._lock = threading.Lock()
        self._loop: asyncio.AbstractEventLoop | None = None
        self._available: asyncio.Semaphore | None = None
        self._thread: threading.Thread | None = None
        self._ready = threading.Event()
        self._tasks: list[asyncio.Task[None]] = []

    @property
    def in_flight(self) -> int:
        with self._lock:
            return self._running + len(self._queue)

    @property
    def alive(self) -> bool:
        """The model loop thread is up."""
        return self._thread is not None and self._thread.is_alive()

    @property
    def running(self) -> int:
        with self._lock:
            return self._running

    def start(self) -> None:
        self._thread = threading.Thread(target=self._run_loop, name="model-loop", daemon=True)
        self._thread.start()
        if not self._ready.wait(timeout=5.0):
            raise RuntimeError("the model event loop did not start within 5 s")

    def stop(self, timeout_s: float = 5.0) -> None:
        loop = self._loop
        if loop is None or self._thread is None:
            return
        with self._lock:
            for job in self._queue:
                job.future.cancel()
            self._queue.clear()
        asyncio.run_coroutine_threadsafe(self._shutdown(), loop)
        self._thread.join(timeout=timeout_s)
        self._thread = None

    def submit(self, key: str, factory: JobFactory) -> concurrent.futures.Future[Any] | None:
        """Queue a job; None when refused (every in-flight job is running)."""
        if self._loop is None or self._available is None:
            raise RuntimeError("Scheduler.start() was not called")
        future: concurrent.futures.Future[Any] = concurrent.futures.Future()
        with self._lock:
            if self._running + len(self._queue) >= self.max_in_flight:
                if not self._queue:
                    self.stats.refused += 1
                    return None
                oldest = self._queue.popleft()
                oldest.future.cancel()
                self.stats.dropped += 1
            self._queue.append(_Job(key, factory, future))
            self.stats.submitted += 1
            self.stats.peak_in_flight = max(
                self.stats.peak_in_flight, self._running + len(self._queue)
            )
        self._loop.call_soon_threadsafe(self._available.release)
        return future

    def _run_loop(self) -> None:
        loop = asyncio.new_event_loop()
        asyncio.set_event_loop(loop)
        self._loop = loop
        self._available = asyncio.Semaphore(0)
        self._tasks = [loop.create_task(self._worker(i)) for i in range(self.workers)]
        self._ready.set()
        try:
            loop.run_forever()
        finally:
            loop.close()

    async def _shutdown(self) -> None:
        for task in self._tasks:
            task.cancel()
        await asyncio.gather(*self._tasks, return_exceptions=True)
        asyncio.get_running_loop().stop()

    async def _worker(self, index: int) -> None:
        assert self._available is not None
        while True:
            await self._available.acquire()
            with self._lock:
                if not self._queue:
                    continue  # its job was dropped
                job = self._queue.popleft()
                self._running += 1
            try:
                await self._execute(job)
            finally:
                with self._lock:
                    self._running -= 1

    async def _execute(self, job: _Job) -> None:
        if not job.future.set_running_or_notify_cancel():
            return
        try:
            async with asyncio.timeout(self.timeout_s):
                result = await job.factory()
        except TimeoutError:
            self.stats.timed_out += 1
            job.future.set_exception(
                JobTimeoutError(f"{job.key}: no result within {self.timeout_s:g} s")
            )
        except asyncio.CancelledError:
            job.future.set_exception(RuntimeError(f"{job.key}: the scheduler stopped"))
            raise
        except Exception as error:  # the job's own failure goes to its future, not the worker
            self.stats.failed += 1
            job.future.set_exception(error)
        else:
            self.stats.completed += 1
            job.future.set_result(result)
