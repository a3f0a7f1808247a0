"""The mission archive under a burst (issue 39): a mission's page is read while writes wait,
and writes that wait together are committed together, each caller answered once its own is."""

from __future__ import annotations

import asyncio
import sqlite3
import time
from pathlib import Path

from robot_voice_chat.agent.archive import SqliteMissionArchive
from robot_voice_chat.socket_events import MissionEventLine


def line(text: str) -> MissionEventLine:
    return MissionEventLine(mission_id="m-1", kind="say", text=text, ts=time.time())


async def test_a_read_does_not_wait_behind_a_blocked_write(tmp_path: Path) -> None:
    archive = SqliteMissionArchive(tmp_path / "missions.sqlite3")
    await archive.append_event(line("first"))
    other = sqlite3.connect(tmp_path / "missions.sqlite3", isolation_level=None)
    other.execute("BEGIN IMMEDIATE")  # another writer holds the database: our writes wait
    try:
        write = asyncio.create_task(archive.append_event(line("second")))
        await asyncio.sleep(0)

        read = await asyncio.wait_for(archive.events("m-1"), timeout=5)

        assert [e.text for e in read] == ["first"]
        assert not write.done()
    finally:
        other.execute("ROLLBACK")
        other.close()
    await asyncio.wait_for(write, timeout=15)
    assert [e.text for e in await archive.events("m-1")] == ["first", "second"]


async def test_a_burst_of_writes_is_committed_and_kept_in_order(tmp_path: Path) -> None:
    archive = SqliteMissionArchive(tmp_path / "missions.sqlite3")

    await asyncio.gather(*(archive.append_event(line(f"line {i}")) for i in range(50)))

    again = SqliteMissionArchive(tmp_path / "missions.sqlite3")  # another process life
    assert [e.text for e in await again.events("m-1")] == [f"line {i}" for i in range(50)]
