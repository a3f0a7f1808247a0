"""TraceRecorder (spec §8): one JSONL file per mission, always on; retention at startup."""

from __future__ import annotations

import asyncio
import json
import time
from pathlib import Path
from typing import Any

import structlog

from robot_voice_chat.operator import operator_fields
from robot_voice_chat.private_files import private_dir, private_file

logger = structlog.get_logger(__name__)


class TraceRecorder:
    """``record`` is cheap and synchronous (buffers); ``flush`` writes off the event loop."""

    def __init__(self, directory: Path) -> None:
        self.directory = directory
        self._buffers: dict[str, list[str]] = {}
        self._lock = asyncio.Lock()

    def record(self, mission_id: str, kind: str, **data: Any) -> None:
        line = json.dumps(
            {"ts": time.time(), "kind": kind, **operator_fields(), **data}, default=str
        )
        self._buffers.setdefault(mission_id, []).append(line)

    async def flush(self) -> None:
        async with self._lock:
            pending, self._buffers = self._buffers, {}
            if pending:
                await asyncio.to_thread(self._write, pending)

    def _write(self, pending: dict[str, list[str]]) -> None:
        private_dir(self.directory)
        for mission_id, lines in pending.items():
            path = private_file(self.directory / f"{mission_id}.jsonl")
            with path.open("a", encoding="utf-8") as f:
                f.write("\n".join(lines) + "\n")

    async def read(self, mission_id: str) -> list[dict[str, Any]]:
        """The mission's records, read and parsed off the event loop (a long mission's trace
        is megabytes of JSON)."""
        await self.flush()
        return await asyncio.to_thread(self._read, self.directory / f"{mission_id}.jsonl")

    @staticmethod
    def _read(path: Path) -> list[dict[str, Any]]:
        if not path.is_file():
            return []
        text = path.read_text(encoding="utf-8")
        return [json.loads(line) for line in text.splitlines() if line.strip()]

    def prune(self, retention_days: int) -> int:
        """Delete traces older than ``retention_days`` (startup only, before serving)."""
        if not self.directory.is_dir():
            return 0
        cutoff = time.time() - retention_days * 86400
        removed = 0
        for path in self.directory.glob("*.jsonl"):
            if path.stat().st_mtime < cutoff:
                path.unlink()
                removed += 1
        if removed:
            logger.info("trace_pruned", removed=removed, retention_days=retention_days)
        return removed

    async def history(self, limit: int) -> list[dict[str, Any]]:
        """Summaries of finished missions from the trace files (for the missions list), read
        off the event loop."""
        return await asyncio.to_thread(self._history, limit)

    def _history(self, limit: int) -> list[dict[str, Any]]:
        if not self.directory.is_dir():
            return []
        rows = []
        paths = sorted(self.directory.glob("*.jsonl"), key=lambda p: p.stat().st_mtime)
        for path in reversed(paths[-limit:]):
            first, last = _first_last(path)
            if first is None:
                continue
            rows.append(
                {
                    "id": path.stem,
                    "instruction": first.get("instruction", ""),
                    "state": (last or {}).get("outcome", "unknown"),
                    "started": first.get("ts"),
                    "ended": (last or {}).get("ts")
                    if (last or {}).get("kind") == "final"
                    else None,
                    "steps": {},
                }
            )
        return rows


def _first_last(path: Path) -> tuple[dict[str, Any] | None, dict[str, Any] | None]:
    lines = path.read_text(encoding="utf-8").splitlines()
    if not lines:
        return None, None
    try:
        return json.loads(lines[0]), json.loads(lines[-1])
    except ValueError:
        return None, None
