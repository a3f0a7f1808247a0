"""Where robot-sim was when it froze: a fresh-clone CI run saw the whole process (its pose, lock
and camera timers alike) stand still for 6.3 s and then 3 s while the host's other processes
ran on. :class:`StallWatch` is armed again by the pose timer about once a second; when it was
not re-armed for ``after_s`` the Python stack of every thread goes to stderr (the service log).
``faulthandler`` writes it from a C thread of its own, so it works while a thread holds the GIL.
"""

from __future__ import annotations

import faulthandler
import sys
import threading
import time
from typing import TextIO

import structlog

logger = structlog.get_logger(__name__)

REARM_EVERY_S = 1.0


class StallWatch:
    def __init__(self, after_s: float, file: TextIO | None = None) -> None:
        if after_s <= REARM_EVERY_S:
            raise ValueError(f"a stall is longer than the re-arm period ({REARM_EVERY_S:g} s)")
        self.after_s = after_s
        self._file = file or sys.stderr
        self._mutex = threading.Lock()
        self._armed_at: float | None = None
        self._closed = False

    def beat(self) -> None:
        """The process runs: re-arm the dump (at most once per ``REARM_EVERY_S``)."""
        now = time.monotonic()
        with self._mutex:
            if self._closed:
                return
            if self._armed_at is not None:
                gap = now - self._armed_at
                if gap < REARM_EVERY_S:
                    return
                if gap > self.after_s:
                    logger.warning("robot_sim_stalled", stalled_s=round(gap - REARM_EVERY_S, 1))
            self._armed_at = now
            faulthandler.dump_traceback_later(self.after_s, repeat=False, file=self._file)

    def close(self) -> None:
        with self._mutex:
            self._closed = True
            faulthandler.cancel_dump_traceback_later()
