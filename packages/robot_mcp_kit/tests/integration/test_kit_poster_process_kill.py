"""A poster process killed (SIGKILL) mid-stream loses nothing: the next poster on the same
outbox delivers the rest, in task order, and continues each task's seq."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

from robot_stack_testing import ProcessLauncher, async_wait_until
from robot_stack_testing.kit.receiver import ReceiverServer, RecordingReceiver, order_violations

SECRET = "kit-test-secret-\u00e9"
PROC = Path(__file__).parent / "procs" / "kit_poster_proc.py"


def emitted_lines(log: str) -> list[tuple[str, str, int]]:
    rows = []
    for line in log.splitlines():
        if line.startswith("EMITTED "):
            _, event_id, task_id, seq = line.split()
            rows.append((event_id, task_id, int(seq)))
    return rows


async def test_a_killed_poster_process_loses_no_emitted_event(
    launcher: ProcessLauncher,
    receiver: RecordingReceiver,
    receiver_server: ReceiverServer,
    outbox_path: Path,
    make_poster: Any,
) -> None:
    await receiver_server.start()
    proc = launcher.start(
        "poster",
        [sys.executable, str(PROC), receiver_server.url, SECRET, str(outbox_path), "3", "0.003"],
    )
    await async_wait_until(lambda: len(receiver.accepted()) >= 30, 30, "first deliveries")
    await receiver_server.stop()  # the receiver goes away too: events pile up in the outbox
    await async_wait_until(
        lambda: len(emitted_lines(proc.log())) >= len(receiver.accepted()) + 20,
        30,
        "events emitted while the receiver is down",
    )
    proc.popen.kill()
    proc.popen.wait(timeout=10)
    emitted = emitted_lines(proc.log())
    assert not proc.running()

    await receiver_server.start()
    poster = make_poster()
    await poster.start()
    follow_up = await poster.emit("proc-0", "navigate_to", "task_done", {"arrived": True})

    wanted = {event_id for event_id, _, _ in emitted} | {follow_up.event_id}
    await async_wait_until(lambda: wanted <= receiver.accepted_ids(), 30, "all events delivered")
    assert order_violations(receiver.deliveries) == []
    last_seq_of_task0 = max(seq for _, task, seq in emitted if task == "proc-0")
    assert follow_up.seq > last_seq_of_task0
