"""Where the latched software stop lives on disk: a state file plus an append-only journal.

``latch.json`` holds the current state (written atomically: temp file, fsync, rename, fsync of
the directory). ``latch.journal`` records every stop and clear (one JSON line each, fsync'd).
The journal is also the marker that a stop was ever recorded: once it exists, a missing or
unreadable state file reads as latched (fail closed). Only a fresh data dir reads as clear.

Reading fails closed (issue 31): the state file must say ``latched`` itself (``{}`` is not a
clear), and a file saying clear while the journal's last record is a stop reads latched. The
directory is 0700 and both files 0600 (what operators said and who stopped the robot); files an
older version left readable are tightened when the store opens.
"""

from __future__ import annotations

import abc
import contextlib
import json
import os
import stat
import time
from pathlib import Path
from typing import Any

import structlog
from pydantic import BaseModel, ConfigDict, ValidationError

from robot_voice_chat.private_files import private_dir

logger = structlog.get_logger(__name__)
STATE_FILE = "latch.json"
JOURNAL_FILE = "latch.journal"
FILE_MODE, DIR_MODE = 0o600, 0o700
_TAIL_BYTES = 65536  # the journal's last record is in its last line


class LatchState(BaseModel):
    """``GET /api/safety`` and readyz report exactly this."""

    latched: bool = False
    since: float | None = None  # epoch seconds of the stop that set the latch
    by: str | None = None
    reason: str | None = None


class _StoredState(LatchState):
    """The state file as read back: ``latched`` must be there (and a real bool)."""

    model_config = ConfigDict(strict=True)

    latched: bool


class LatchStore(abc.ABC):
    """Port: persist the latch (blocking calls; the latch runs them off the event loop)."""

    @abc.abstractmethod
    def load(self) -> LatchState: ...

    @abc.abstractmethod
    def save(self, state: LatchState, record: dict[str, Any]) -> None:
        """Persist ``state`` and append ``record`` (who, why, what) to the journal."""


class MemoryLatchStore(LatchStore):
    """Keeps the latch for one process life (tests; never a deployment)."""

    def __init__(self, state: LatchState | None = None) -> None:
        self.state = state or LatchState()
        self.journal: list[dict[str, Any]] = []

    def load(self) -> LatchState:
        return self.state.model_copy()

    def save(self, state: LatchState, record: dict[str, Any]) -> None:
        self.state = state.model_copy()
        self.journal.append(dict(record))


def _fsync_dir(directory: Path) -> None:
    fd = os.open(directory, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def atomic_write(path: Path, text: str) -> None:
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, FILE_MODE)
    with os.fdopen(fd, "w", encoding="utf-8") as handle:
        handle.write(text)
        handle.flush()
        os.fsync(handle.fileno())
    tmp.replace(path)
    _fsync_dir(path.parent)


def last_record(path: Path) -> dict[str, Any] | None:
    """The journal's last complete record (None: no journal, empty or unreadable tail)."""
    try:
        with path.open("rb") as handle:
            handle.seek(0, os.SEEK_END)
            handle.seek(max(0, handle.tell() - _TAIL_BYTES))
            tail = handle.read()
    except OSError:
        return None
    for line in reversed(tail.splitlines()):
        try:
            record = json.loads(line)
        except ValueError:
            continue  # a torn last line (a crash mid-append): the one before counts
        return record if isinstance(record, dict) else None
    return None


class FileLatchStore(LatchStore):
    def __init__(self, directory: Path) -> None:
        self.directory = directory
        self.state_path = directory / STATE_FILE
        self.journal_path = directory / JOURNAL_FILE

    def load(self) -> LatchState:
        self._tighten()
        recorded = self.journal_path.exists()
        try:
            raw = self.state_path.read_text(encoding="utf-8")
        except FileNotFoundError:
            if not recorded:
                return LatchState()  # a fresh data dir: no stop was ever recorded
            return self._fail_closed("the latch file is missing")
        except OSError as exc:
            return self._fail_closed(f"the latch file cannot be read ({exc.strerror})")
        try:
            state = LatchState(**_StoredState.model_validate(json.loads(raw)).model_dump())
        except (ValueError, ValidationError):
            return self._fail_closed("the latch file is corrupt")
        last = last_record(self.journal_path) if recorded else None
        if not state.latched and last is not None and last.get("event") == "stop":
            return self._fail_closed("the latch file says clear but the last record is a stop")
        return state

    def _tighten(self) -> None:
        """0700/0600 for what an older version (or a umask) left readable to others."""
        for path, mode in (
            (self.directory, DIR_MODE),
            (self.state_path, FILE_MODE),
            (self.journal_path, FILE_MODE),
        ):
            with contextlib.suppress(FileNotFoundError):
                if stat.S_IMODE(path.stat().st_mode) != mode:
                    path.chmod(mode)

    def _fail_closed(self, why: str) -> LatchState:
        logger.error("safety_latch_unreadable", path=str(self.state_path), why=why)
        return LatchState(
            latched=True,
            since=time.time(),
            by="unknown",
            reason=f"{why} after a recorded stop; treated as latched (check the robot, "
            "then Clear stop)",
        )

    def save(self, state: LatchState, record: dict[str, Any]) -> None:
        private_dir(self.directory)
        if state.latched:  # state first: a crash before the journal line still reads latched
            atomic_write(self.state_path, state.model_dump_json())
            append_record(self.journal_path, record)
        else:  # journal first: a crash before the state write still reads latched
            append_record(self.journal_path, record)
            atomic_write(self.state_path, state.model_dump_json())


def append_record(path: Path, record: dict[str, Any]) -> None:
    """Append one JSON line and fsync it (append-only journals and audit logs; a new file is
    0600 in a directory created 0700)."""
    created = not path.exists()
    private_dir(path.parent)
    fd = os.open(path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, FILE_MODE)
    with os.fdopen(fd, "a", encoding="utf-8") as handle:
        handle.write(json.dumps(record, separators=(",", ":"), default=str) + "\n")
        handle.flush()
        os.fsync(handle.fileno())
    if created:
        _fsync_dir(path.parent)
