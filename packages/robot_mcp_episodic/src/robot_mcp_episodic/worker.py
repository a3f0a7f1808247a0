"""The background worker thread: flushes the index and the open MCAP chunk every ``flush_s``
(the most a crash loses), polls the ROS graph for new skill topics and runs retention every
``janitor_s``. Its failures are logged and retried; it never touches the ingest path."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import dataclass

import structlog

logger = structlog.get_logger(__name__)


@dataclass(frozen=True)
class Job:
    name: str
    every_s: float
    run: Callable[[], object]


class Worker:
    def __init__(self, jobs: list[Job], tick_s: float = 0.1) -> None:
        self._jobs = jobs
        self._tick_s = tick_s
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._loop, name="episodic-worker", daemon=True)
        self._due = {job.name: 0.0 for job in jobs}

    def start(self) -> None:
        self._thread.start()

    def stop(self, timeout_s: float = 10.0) -> None:
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(timeout_s)

    def run_due(self, now: float) -> None:
        for job in self._jobs:
            if now < self._due[job.name]:
                continue
            self._due[job.name] = now + job.every_s
            try:
                job.run()
            except Exception:
                logger.exception("episodic_job_failed", job=job.name)

    def _loop(self) -> None:
        while not self._stop.wait(self._tick_s):
            self.run_due(time.monotonic())
