"""Cost-control policy of spec 000 §8: meter and gate every cloud stage.

A skill's *local* stages always run at its rate. A *cloud* stage runs only if the skill is
``once`` / prewarm, or (continuous skills) the frame-difference gate passed (when
``cloud_requires_gate``), the skill's cloud rate stays ≤ ``max_cloud_rate_hz`` and the global
``max_cloud_calls_per_min`` budget has headroom. Otherwise the tick is skipped with a reason
(the node logs ``cloud_call_skipped`` and republishes the last result marked stale).

Also here: the prewarm grounding cache (``prewarm_ttl_s``). A grounding holds pixel
coordinates of the frame it was made on, so an entry also keeps that scene (a frame-difference
gate seeded with it) and is dropped when a later skill asks on a frame showing another scene:
a box from another view would send the segmenter to the wrong pixels.
"""

from __future__ import annotations

import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass

import structlog

from robot_mcp_perception.models.base import GroundingResult, Image
from robot_mcp_perception.registry import Gate
from robot_mcp_perception.settings import CostSettings
from robot_mcp_perception.skills import Skill

Clock = Callable[[], float]

logger = structlog.get_logger("robot_mcp_perception.cost")


SKIP_GATE = "scene_unchanged"
SKIP_RATE = "max_cloud_rate_hz"
SKIP_BUDGET = "max_cloud_calls_per_min"


@dataclass(frozen=True)
class CloudDecision:
    allowed: bool
    reason: str = ""


class CloudBudget:
    """Sliding 60 s window of cloud calls across all skills (thread-safe)."""

    def __init__(self, max_per_min: int, clock: Clock = time.monotonic) -> None:
        self.max_per_min = max_per_min
        self._clock = clock
        self._calls: deque[float] = deque()
        self._lock = threading.Lock()
        self.total = 0

    def _trim(self, now: float) -> None:
        while self._calls and now - self._calls[0] >= 60.0:
            self._calls.popleft()

    def used(self) -> int:
        with self._lock:
            self._trim(self._clock())
            return len(self._calls)

    def has_headroom(self) -> bool:
        return self.used() < self.max_per_min

    def record(self) -> None:
        with self._lock:
            now = self._clock()
            self._trim(now)
            self._calls.append(now)
            self.total += 1


class CostPolicy:
    """Decides whether a skill may fire its cloud stage this tick (§8 rules)."""

    def __init__(self, settings: CostSettings, clock: Clock = time.monotonic) -> None:
        self.settings = settings
        self.budget = CloudBudget(settings.max_cloud_calls_per_min, clock)
        self._clock = clock
        self._last_call: dict[str, float] = {}
        self._lock = threading.Lock()

    def needs_gate(self, skill: Skill, always_gated: bool = False) -> bool:
        """Whether the frame-difference gate must pass before this skill's cloud stage."""
        if skill.once or skill.prewarm:
            return False
        return always_gated or self.settings.cloud_requires_gate

    def check(self, skill: Skill) -> CloudDecision:
        """Rate and budget rules (no side effects); the gate is checked by the caller after."""
        if skill.once or skill.prewarm:
            return CloudDecision(True)
        now = self._clock()
        with self._lock:
            last = self._last_call.get(skill.name)
        if last is not None and now - last < 1.0 / self.settings.max_cloud_rate_hz - 1e-3:
            return CloudDecision(False, SKIP_RATE)
        if not self.budget.has_headroom():
            return CloudDecision(False, SKIP_BUDGET)
        return CloudDecision(True)

    def record(self, skill: Skill) -> None:
        """Count a cloud call that is about to be made."""
        with self._lock:
            self._last_call[skill.name] = self._clock()
        self.budget.record()

    def forget(self, skill_name: str) -> None:
        with self._lock:
            self._last_call.pop(skill_name, None)


def grounding_key(skill: Skill) -> tuple[object, ...]:
    """Skills with the same key would ask the grounder the same question."""
    return (
        skill.mode,
        skill.grounding.strip().lower(),
        tuple((o.name, o.type, o.description) for o in skill.outputs),
    )


class PrewarmCache:
    """Groundings kept for ``ttl_s`` so a later skill with the same grounding skips the grounder."""

    def __init__(self, ttl_s: float, clock: Clock = time.monotonic, max_entries: int = 64) -> None:
        self.ttl_s = ttl_s
        self._clock = clock
        self._max_entries = max_entries
        self._entries: dict[tuple[object, ...], _Entry] = {}
        self._lock = threading.Lock()
        self.hits = 0
        self.scene_changed = 0

    def put(self, skill: Skill, grounding: GroundingResult, scene: Gate | None = None) -> None:
        with self._lock:
            self._expire()
            if len(self._entries) >= self._max_entries:
                oldest = min(self._entries, key=lambda k: self._entries[k].at)
                del self._entries[oldest]
            self._entries[grounding_key(skill)] = _Entry(self._clock(), grounding, scene)

    def get(self, skill: Skill, image: Image | None = None) -> GroundingResult | None:
        """The cached grounding for ``skill``'s question, if fresh and made on this scene
        (``image``); an entry whose scene differs from ``image`` is dropped."""
        with self._lock:
            self._expire()
            key = grounding_key(skill)
            entry = self._entries.get(key)
            if entry is None:
                return None
            if image is not None and entry.scene is not None and entry.scene.passes(image):
                del self._entries[key]
                self.scene_changed += 1
                logger.info("prewarm_dropped", skill=skill.name, reason="scene_changed")
                return None
            self.hits += 1
            return entry.grounding

    def __len__(self) -> int:
        with self._lock:
            self._expire()
            return len(self._entries)

    def _expire(self) -> None:
        now = self._clock()
        for key in [k for k, e in self._entries.items() if now - e.at > self.ttl_s]:
            del self._entries[key]


@dataclass(frozen=True)
class _Entry:
    at: float
    grounding: GroundingResult
    scene: Gate | None
    """A frame-difference gate seeded with the frame the grounding was made on."""
