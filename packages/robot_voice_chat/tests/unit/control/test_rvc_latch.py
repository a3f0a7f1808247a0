"""The latched software stop on disk: fsync'd, fail closed, cleared only with who and why."""

from __future__ import annotations

import json
import stat
from pathlib import Path

import pytest

from robot_voice_chat.control.latch import NotLatchedError, SafetyLatch
from robot_voice_chat.control.latch_store import FileLatchStore, LatchState
from robot_voice_chat.operator import acting_operator


def test_a_fresh_data_dir_is_not_latched(tmp_path: Path) -> None:
    assert FileLatchStore(tmp_path / "safety").load() == LatchState()


async def test_a_stop_survives_a_new_latch_on_the_same_dir(tmp_path: Path) -> None:
    latch = SafetyLatch(FileLatchStore(tmp_path))
    await latch.stop("alice", "Stop robot (operator UI)")

    again = SafetyLatch(FileLatchStore(tmp_path)).state
    assert again.latched is True
    assert again.by == "alice"
    assert again.reason == "Stop robot (operator UI)"
    assert again.since is not None


async def test_a_corrupt_latch_file_reads_latched(tmp_path: Path) -> None:
    await SafetyLatch(FileLatchStore(tmp_path)).stop("alice", "stop")
    (tmp_path / "latch.json").write_text('{"latched": fal')

    state = FileLatchStore(tmp_path).load()
    assert state.latched is True
    assert "corrupt" in (state.reason or "")


async def test_a_missing_latch_file_after_a_recorded_stop_reads_latched(tmp_path: Path) -> None:
    latch = SafetyLatch(FileLatchStore(tmp_path))
    await latch.stop("alice", "stop")
    await latch.clear("bob", "area checked")  # even after a clear: the record exists
    (tmp_path / "latch.json").unlink()

    state = FileLatchStore(tmp_path).load()
    assert state.latched is True
    assert "missing" in (state.reason or "")


async def test_a_latch_file_of_the_wrong_shape_reads_latched(tmp_path: Path) -> None:
    await SafetyLatch(FileLatchStore(tmp_path)).stop("alice", "stop")
    (tmp_path / "latch.json").write_text('{"latched": "maybe"}')
    assert FileLatchStore(tmp_path).load().latched is True


async def test_clear_records_the_operator_and_why_in_the_journal(tmp_path: Path) -> None:
    latch = SafetyLatch(FileLatchStore(tmp_path))
    await latch.stop("alice", "person in the corridor")
    with acting_operator("bob"):
        state = await latch.clear("bob", "corridor is empty again")

    assert state == LatchState()
    assert SafetyLatch(FileLatchStore(tmp_path)).latched is False
    lines = [json.loads(x) for x in (tmp_path / "latch.journal").read_text().splitlines()]
    assert [x["event"] for x in lines] == ["stop", "clear"]
    assert lines[1]["by"] == "bob"
    assert lines[1]["reason"] == "corridor is empty again"
    assert lines[1]["stop"]["by"] == "alice"


async def test_clear_without_a_stop_is_refused(tmp_path: Path) -> None:
    with pytest.raises(NotLatchedError):
        await SafetyLatch(FileLatchStore(tmp_path)).clear("bob", "nothing to clear")


async def test_a_second_stop_keeps_the_first_one(tmp_path: Path) -> None:
    latch = SafetyLatch(FileLatchStore(tmp_path))
    first = await latch.stop("alice", "first")
    second = await latch.stop("bob", "second")
    assert second == first


async def test_listeners_hear_stop_and_clear(tmp_path: Path) -> None:
    heard: list[bool] = []
    latch = SafetyLatch(FileLatchStore(tmp_path))

    async def listen(state: LatchState) -> None:
        heard.append(state.latched)

    latch.add_listener(listen)
    await latch.stop("alice", "stop")
    await latch.clear("alice", "clear it")
    assert heard == [True, False]


async def test_a_clear_that_cannot_be_written_leaves_the_latch_set(tmp_path: Path) -> None:
    latch = SafetyLatch(FileLatchStore(tmp_path))
    await latch.stop("alice", "stop")
    (tmp_path / "latch.journal").unlink()
    (tmp_path / "latch.journal").mkdir()  # appending to it now fails like a full/broken disk

    with pytest.raises(OSError):
        await latch.clear("bob", "try to clear")
    assert latch.latched is True


@pytest.mark.parametrize("written", ["{}", '{"latched": false}', "null", "[]"])
async def test_a_latch_file_saying_clear_while_the_journal_ends_in_a_stop_reads_latched(
    tmp_path: Path, written: str
) -> None:
    """Issue 31: ``{}`` validated as the default state (clear) after a recorded stop."""
    await SafetyLatch(FileLatchStore(tmp_path)).stop("alice", "stop")
    (tmp_path / "latch.json").write_text(written)
    state = FileLatchStore(tmp_path).load()
    assert state.latched is True
    assert state.reason is not None


async def test_a_cleared_latch_reads_clear_and_a_stop_after_it_latched_again(
    tmp_path: Path,
) -> None:
    latch = SafetyLatch(FileLatchStore(tmp_path))
    await latch.stop("alice", "stop")
    await latch.clear("bob", "area checked")
    assert FileLatchStore(tmp_path).load().latched is False
    await latch.stop("carol", "again")
    assert FileLatchStore(tmp_path).load().by == "carol"


async def test_latch_files_are_for_the_brains_user_only(tmp_path: Path) -> None:
    """Issue 31: latch.json and the journal were 0644 in a 0755 directory."""
    safety = tmp_path / "data" / "safety"
    latch = SafetyLatch(FileLatchStore(safety))
    await latch.stop("alice", "stop")
    await latch.clear("bob", "area checked")
    assert stat.S_IMODE(safety.stat().st_mode) == 0o700
    for name in ("latch.json", "latch.journal"):
        assert stat.S_IMODE((safety / name).stat().st_mode) == 0o600, name
    # files an older version left readable are tightened at the next start
    (safety / "latch.json").chmod(0o644)
    (safety / "latch.journal").chmod(0o644)
    safety.chmod(0o755)
    assert FileLatchStore(safety).load().latched is False
    assert stat.S_IMODE(safety.stat().st_mode) == 0o700
    assert stat.S_IMODE((safety / "latch.json").stat().st_mode) == 0o600
    assert stat.S_IMODE((safety / "latch.journal").stat().st_mode) == 0o600
