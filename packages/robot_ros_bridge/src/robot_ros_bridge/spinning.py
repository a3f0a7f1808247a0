"""Spinning an executor until shutdown, as a process boundary (the bridge's spin thread,
robot-sim, the vision node).

An exception that reaches ``executor.spin()`` ends it: a callback that raised, rmw failing to
send a service reply to a client it has not matched yet, or an entity that a callback destroyed
while another executor thread was building its wait set (rclpy's ``InvalidHandle``: "cannot use
Destroyable because destruction was requested" — it took the vision node down in a busy CI run
as a skill's publishers were destroyed). Each is logged and spinning goes on; the next turn
builds its wait set without the destroyed entity.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any

import rclpy
import structlog
from rclpy.executors import ExternalShutdownException

logger = structlog.get_logger(__name__)


def spin_until_shutdown(
    executor: Any, running: Callable[[], bool] = rclpy.ok, *, turn_s: float | None = None
) -> None:
    """Spin ``executor`` while ``running()``; Ctrl-C and an external shutdown end it (raised).

    With ``turn_s`` it spins one wait at a time, checking ``running()`` at least every
    ``turn_s``: a thread spinning for another (the bridge's) then ends *before* its executor is
    shut down. rclpy's ``Executor.shutdown`` destroys the guard condition at once, under a wait
    that may still hold it (a test peer segfaulted on stop that way in a busy CI run).
    """
    while running():
        try:
            if turn_s is None:
                executor.spin()
            else:
                executor.spin_once(timeout_sec=turn_s)
        except (KeyboardInterrupt, ExternalShutdownException):
            raise
        except Exception:  # the spin loop is the process's boundary
            if not running():
                return
            logger.exception("ros_callback_failed")


def drain_callbacks(executor: Any, timeout_s: float) -> None:
    """Let callbacks already handed to a multi-threaded executor's pool finish (call it after
    the spin loop ended, before ``executor.shutdown``): each triggers the executor's guard
    condition, which ``Executor.shutdown`` destroys without waiting for them (its wait is
    skipped once the shutdown flag is set; the pool is joined only after)."""
    pool = getattr(executor, "_executor", None)  # MultiThreadedExecutor's ThreadPoolExecutor
    if pool is None:
        return
    drainer = threading.Thread(target=pool.shutdown, kwargs={"wait": True}, daemon=True)
    drainer.start()
    drainer.join(timeout=timeout_s)
