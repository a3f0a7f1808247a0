"""The rolling buffer: per skill, the recent detection results and semantic output values,
bounded by count and by age. Pure Python, thread-safe (ROS callbacks write from executor
threads, MCP tools read from the event loop). No ROS, no pixels.
"""

from __future__ import annotations

import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any


@dataclass(frozen=True)
class Result:
    """One ``detections_meta`` message: ``stamp`` is the source image stamp (unix s)."""

    stamp: float
    detections: tuple[dict[str, Any], ...]
    received: float
    source: bytes | None = None
    """The publisher's GID (which incarnation of the skill published it), if known."""
    meta: dict[str, Any] = field(default_factory=dict)
    """The result-level JSON ``extra`` (stale markers, grounding provenance), if sent."""


@dataclass(frozen=True)
class OutputValue:
    """One semantic output message; ``value`` is the JSON-decoded ``data``."""

    output: str
    value: Any
    stamp: float
    received: float
    source: bytes | None = None


@dataclass
class SkillBuffer:
    skill: str
    results: deque[Result]
    outputs: dict[str, deque[OutputValue]] = field(default_factory=dict)
    seq: int = 0
    """Bumped on every write; lets waiters tell "something new arrived"."""

    def last_stamp(self) -> float | None:
        stamps = [self.results[-1].stamp] if self.results else []
        stamps += [values[-1].stamp for values in self.outputs.values() if values]
        return max(stamps) if stamps else None


Listener = Callable[[str, "Result | OutputValue"], None]


class RollingBuffer:
    """All skills' buffers. ``max_count`` per stream, ``max_age_s`` by receive time."""

    def __init__(
        self,
        max_count: int = 50,
        max_age_s: float = 300.0,
        clock: Callable[[], float] = time.time,
    ) -> None:
        if max_count < 1 or max_age_s <= 0:
            raise ValueError("max_count must be >= 1 and max_age_s > 0")
        self.max_count = max_count
        self.max_age_s = max_age_s
        self._clock = clock
        self._lock = threading.Lock()
        self._skills: dict[str, SkillBuffer] = {}
        self._listeners: list[Listener] = []

    def add_listener(self, listener: Listener) -> None:
        """Called (on the writer's thread, outside the lock) after every write."""
        self._listeners.append(listener)

    # -- writes --------------------------------------------------------------------------
    def add_result(
        self,
        skill: str,
        stamp: float,
        detections: list[dict[str, Any]] | tuple[dict[str, Any], ...],
        source: bytes | None = None,
        meta: dict[str, Any] | None = None,
    ) -> Result:
        result = Result(
            stamp=stamp,
            detections=tuple(detections),
            received=self._clock(),
            source=source,
            meta=dict(meta or {}),
        )
        with self._lock:
            buf = self._ensure(skill)
            buf.results.append(result)
            buf.seq += 1
            self._prune(buf, result.received)
        self._notify(skill, result)
        return result

    def add_output(
        self, skill: str, output: str, value: Any, stamp: float, source: bytes | None = None
    ) -> OutputValue:
        item = OutputValue(
            output=output, value=value, stamp=stamp, received=self._clock(), source=source
        )
        with self._lock:
            buf = self._ensure(skill)
            values = buf.outputs.setdefault(output, deque(maxlen=self.max_count))
            values.append(item)
            buf.seq += 1
            self._prune(buf, item.received)
        self._notify(skill, item)
        return item

    def drop(self, skill: str) -> bool:
        with self._lock:
            return self._skills.pop(skill, None) is not None

    def retire(self, skill: str, sources: set[bytes] | frozenset[bytes]) -> int:
        """Forget every entry of ``skill`` published by one of ``sources`` (publishers that
        are gone: a stopped skill, or the previous skill of the same name); a buffer left
        empty is dropped. Returns how many entries went."""
        with self._lock:
            buf = self._skills.get(skill)
            if buf is None or not sources:
                return 0
            before = len(buf.results) + sum(len(v) for v in buf.outputs.values())
            buf.results = deque(
                (r for r in buf.results if r.source not in sources), maxlen=self.max_count
            )
            for name, values in list(buf.outputs.items()):
                kept = deque((v for v in values if v.source not in sources), maxlen=self.max_count)
                if kept:
                    buf.outputs[name] = kept
                else:
                    del buf.outputs[name]
            after = len(buf.results) + sum(len(v) for v in buf.outputs.values())
            if after == 0:
                del self._skills[skill]
            elif after != before:
                buf.seq += 1
            return before - after

    # -- reads ---------------------------------------------------------------------------
    def skills(self) -> list[str]:
        with self._lock:
            return sorted(self._skills)

    def seq(self, skill: str) -> int:
        with self._lock:
            buf = self._skills.get(skill)
            return buf.seq if buf is not None else 0

    def snapshot(self, skill: str) -> SkillBuffer | None:
        """A copy of one skill's buffer (age-pruned), safe to read without the lock."""
        with self._lock:
            buf = self._skills.get(skill)
            if buf is None:
                return None
            self._prune(buf, self._clock())
            return SkillBuffer(
                skill=buf.skill,
                results=deque(buf.results),
                outputs={name: deque(values) for name, values in buf.outputs.items()},
                seq=buf.seq,
            )

    def latest_output(self, skill: str, output: str) -> OutputValue | None:
        with self._lock:
            buf = self._skills.get(skill)
            values = buf.outputs.get(output) if buf is not None else None
            return values[-1] if values else None

    # -- internals -----------------------------------------------------------------------
    def _ensure(self, skill: str) -> SkillBuffer:
        buf = self._skills.get(skill)
        if buf is None:
            buf = SkillBuffer(skill=skill, results=deque(maxlen=self.max_count))
            self._skills[skill] = buf
        return buf

    def _prune(self, buf: SkillBuffer, now: float) -> None:
        horizon = now - self.max_age_s
        while buf.results and buf.results[0].received < horizon:
            buf.results.popleft()
        for values in buf.outputs.values():
            while values and values[0].received < horizon:
                values.popleft()

    def _notify(self, skill: str, item: Result | OutputValue) -> None:
        for listener in self._listeners:
            listener(skill, item)
