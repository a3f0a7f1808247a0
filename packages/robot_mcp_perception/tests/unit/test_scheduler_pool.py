"""Scheduler: N workers, max_in_flight, drop-oldest, per-call timeout."""

from __future__ import annotations

import asyncio
import concurrent.futures
import threading
from collections.abc import Awaitable, Callable, Iterator

import pytest

from robot_mcp_perception.scheduler import JobTimeoutError, Scheduler
from robot_stack_testing import wait_until


@pytest.fixture
def scheduler() -> Iterator[Scheduler]:
    pool = Scheduler(workers=1, max_in_flight=2, timeout_s=0.5)
    pool.start()
    yield pool
    pool.stop()


def _blocking_job(release: threading.Event, value: int) -> Callable[[], Awaitable[int]]:
    async def job() -> int:
        await asyncio.to_thread(release.wait, 10.0)
        return value

    return job


def test_results_are_delivered_through_futures(scheduler: Scheduler) -> None:
    async def job() -> str:
        return "done"

    future = scheduler.submit("a", job)

    assert future is not None
    assert future.result(timeout=5.0) == "done"
    assert scheduler.stats.completed == 1


def test_when_full_the_oldest_queued_job_is_dropped(scheduler: Scheduler) -> None:
    release = threading.Event()
    running = scheduler.submit("a", _blocking_job(release, 1))
    wait_until(lambda: scheduler.running == 1, 5.0, "the first job running")
    queued_old = scheduler.submit("b", _blocking_job(release, 2))
    queued_new = scheduler.submit("c", _blocking_job(release, 3))

    assert scheduler.in_flight == 2
    release.set()

    assert running is not None
    assert queued_old is not None
    assert queued_new is not None
    assert running.result(timeout=5.0) == 1
    assert queued_old.cancelled()
    assert queued_new.result(timeout=5.0) == 3
    assert scheduler.stats.dropped == 1
    assert scheduler.stats.peak_in_flight == 2


def test_a_job_is_refused_when_every_in_flight_job_is_running() -> None:
    pool = Scheduler(workers=2, max_in_flight=2, timeout_s=5.0)
    pool.start()
    release = threading.Event()
    try:
        first = pool.submit("a", _blocking_job(release, 1))
        second = pool.submit("b", _blocking_job(release, 2))
        wait_until(lambda: pool.in_flight == 2, 5.0)
        wait_until(lambda: pool.running == 2, 5.0, "both running")

        refused = pool.submit("c", _blocking_job(release, 3))

        assert refused is None
        assert pool.stats.refused == 1
        release.set()
        assert first is not None
        assert second is not None
        assert (first.result(timeout=5.0), second.result(timeout=5.0)) == (1, 2)
    finally:
        pool.stop()


def test_a_hung_job_times_out_and_frees_its_worker(scheduler: Scheduler) -> None:
    async def hang() -> None:
        await asyncio.sleep(3600)

    async def quick() -> str:
        return "ok"

    hung = scheduler.submit("slow", hang)
    assert hung is not None
    with pytest.raises(JobTimeoutError):
        hung.result(timeout=5.0)
    after = scheduler.submit("fast", quick)

    assert after is not None
    assert after.result(timeout=5.0) == "ok"
    assert scheduler.stats.timed_out == 1


def test_a_failing_job_reports_its_exception(scheduler: Scheduler) -> None:
    async def boom() -> None:
        raise ValueError("bad frame")

    future = scheduler.submit("x", boom)

    assert future is not None
    with pytest.raises(ValueError, match="bad frame"):
        future.result(timeout=5.0)
    assert scheduler.stats.failed == 1


def test_submit_before_start_is_an_error() -> None:
    async def job() -> None:
        return None

    with pytest.raises(RuntimeError, match="start"):
        Scheduler().submit("x", job)


def test_invalid_sizes_are_refused() -> None:
    with pytest.raises(ValueError):
        Scheduler(workers=0)


def test_stop_fails_queued_jobs() -> None:
    pool = Scheduler(workers=1, max_in_flight=3, timeout_s=5.0)
    pool.start()
    release = threading.Event()
    running = pool.submit("a", _blocking_job(release, 1))
    wait_until(lambda: pool.running == 1, 5.0)
    queued = pool.submit("b", _blocking_job(release, 2))

    pool.stop()

    assert queued is not None
    assert queued.cancelled()
    assert running is not None
    with pytest.raises((RuntimeError, concurrent.futures.CancelledError)):
        running.result(timeout=5.0)
