"""The stall watch: a robot-sim that stops re-arming it dumps every thread's stack."""

from __future__ import annotations

from pathlib import Path

import pytest

from robot_sim.stall_watch import StallWatch
from robot_stack_testing import wait_until


def test_a_process_that_stops_beating_dumps_every_threads_stack(tmp_path: Path) -> None:
    out = tmp_path / "stderr.txt"
    with out.open("w") as file:
        watch = StallWatch(1.2, file=file)
        try:
            watch.beat()  # and then nothing: the process "froze"
            wait_until(lambda: "Thread" in out.read_text(), 10, "the stacks dumped")
        finally:
            watch.close()
    assert "test_a_process_that_stops_beating" in out.read_text()  # the frozen test's own frame


def test_a_beating_process_dumps_nothing_and_a_closed_watch_never(tmp_path: Path) -> None:
    out = tmp_path / "stderr.txt"
    with out.open("w") as file:
        watch = StallWatch(1.5, file=file)
        watch.beat()
        watch.close()
        watch.beat()  # closed: not armed again
        with pytest.raises(TimeoutError):
            wait_until(lambda: out.read_text() != "", 2.0, "a dump")
    assert out.read_text() == ""


def test_a_stall_must_be_longer_than_the_rearm_period() -> None:
    with pytest.raises(ValueError, match="re-arm period"):
        StallWatch(0.5)
