"""Where the latched software stop lives on disk: a state file plus an append-only journal.

``latch.json`` holds the current state (written atomically: temp file, fsync, rename, fsync of
the directory). ``latch.journal`` records every stop and clear (one JSON line each, fsync'd).
The journal is also the marker that a stop was ever recorded: once it exists, a missing or
unreadable state file reads as latched (fail closed). Only a fresh data dir reads as clear.
"""

from __future__ import annotations

import abc
import json
import os
import time
from pathlib import Path
from typing import Any

import structlog
from pydantic import BaseModel, ValidationError

logger = structlog.get_logger(__name__)
STATE_FILE = "latch.json"
JOURNAL_FILE = "latch.journal"


class LatchState(BaseModel):
    """``GET /api/safety`` and readyz report exactly this."""

    latched: bool = False
    since: float | None = None  # epoch seconds of the stop that set the latch
    by: str | None = None
    reason: str | None = None


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
    with tmp.open("w", encoding="utf-8") as handle:
        handle.write(text)
        handle.flush()
        os.fsync(handle.fileno())
    tmp.replace(path)
    _fsync_dir(path.parent)


class FileLatchStore(LatchStore):
    def __init__(self, directory: Path) -> None:
        self.directory = directory
        self.state_path = directory / STATE_FILE
        self.journal_path = directory / JOURNAL_FILE

    def load(self) -> LatchState:
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
            return LatchState.model_validate(json.loads(raw))
        except (ValueError, ValidationError):
            return self._fail_closed("the latch file is corrupt")

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
        self.directory.mkdir(parents=True, exist_ok=True)
        if state.latched:  # state first: a crash before the journal line still reads latched
            atomic_write(self.state_path, state.model_dump_json())
            append_record(self.journal_path, record)
        else:  # journal first: a crash before the state write still reads latched
            append_record(self.journal_path, record)
            atomic_write(self.state_path, state.model_dump_json())


def append_record(path: Path, record: dict[str, Any]) -> None:
    """Append one JSON line and fsync it (append-only journals and audit logs)."""
    created = not path.exists()
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("a", encoding="utf-8") as handle:
        handle.write(json.dumps(record, separators=(",", ":"), default=str) + "\n")
        handle.flush()
        os.fsync(handle.fileno())
    if created:
        _fsync_dir(path.parent)
