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
from robot_mcp_perception.registry import Gate, GroundingSource
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
    meter: RunMeter | RefusingMeter | None = None
    """The run's reservation (allowed decisions only); charge each request to it."""


class CloudBudget:
    """Sliding 60 s window of cloud requests across all skills (thread-safe)."""

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

    def has_headroom(self, requests: int = 1) -> bool:
        return self.used() + requests <= self.max_per_min

    def take(self, requests: int, enforce: bool = True) -> float | None:
        """Count ``requests`` now; None (nothing counted) when enforced and they do not fit."""
        with self._lock:
            now = self._clock()
            self._trim(now)
            if enforce and len(self._calls) + requests > self.max_per_min:
                return None
            self._calls.extend([now] * requests)
            self.total += requests
            return now

    def release(self, at: float, requests: int) -> None:
        """Un-count ``requests`` taken at ``at`` that were never sent."""
        with self._lock:
            for _ in range(requests):
                if at not in self._calls:
                    return  # already out of the window
                self._calls.remove(at)
                self.total -= 1

    def record(self) -> None:
        self.take(1, enforce=False)


class RunMeter:
    """One run's cloud requests: ``reserved`` were counted up front, charges beyond them are
    counted as they come (retries) and, when ``enforce``, refused once the budget is spent."""

    def __init__(
        self, policy: CostPolicy, skill: str, reserved: int, enforce: bool, at: float | None
    ) -> None:
        self._policy = policy
        self.skill = skill
        self.reserved = reserved
        self.enforce = enforce
        self._at = at
        self.charged = 0
        self._closed = False
        self._lock = threading.Lock()

    def charge(self) -> bool:
        with self._lock:
            if self.charged < self.reserved and not self._closed:
                self.charged += 1
                return True
        if not self._policy.charge_extra(self.skill, self.enforce):
            return False
        with self._lock:
            self.charged += 1
        return True

    def close(self) -> None:
        """The run ended: give back the reserved requests it did not send."""
        with self._lock:
            if self._closed:
                return
            self._closed = True
            unused = max(0, self.reserved - self.charged)
        if unused and self._at is not None:
            self._policy.release(self.skill, self._at, unused)


class RefusingMeter:
    """A run's meter when the budget is spent but a local fallback can answer: every cloud
    charge is refused (nothing is sent or counted), so a grounder chain answers locally."""

    def charge(self) -> bool:
        return False

    def close(self) -> None:
        return None


class CostPolicy:
    """Decides whether a skill may send its cloud requests this tick (§8 rules), per request:
    the global budget counts every request, and a skill's ``max_cloud_rate_hz`` spaces its
    requests (a run of n requests pushes the skill's next run n / rate seconds away)."""

    def __init__(self, settings: CostSettings, clock: Clock = time.monotonic) -> None:
        self.settings = settings
        self.budget = CloudBudget(settings.max_cloud_calls_per_min, clock)
        self._clock = clock
        self._free_at: dict[str, float] = {}
        self._lock = threading.Lock()

    def needs_gate(self, skill: Skill, always_gated: bool = False) -> bool:
        """Whether the frame-difference gate must pass before this skill's cloud stage."""
        if skill.once or skill.prewarm:
            return False
        return always_gated or self.settings.cloud_requires_gate

    def reserve(self, skill: Skill, requests: int) -> CloudDecision:
        """Reserve a run's ``requests`` (all or nothing). ``once`` / prewarm skills always may
        (their requests are still counted); others are refused by rate or budget."""
        enforce = not (skill.once or skill.prewarm)
        period = 1.0 / self.settings.max_cloud_rate_hz
        with self._lock:
            now = self._clock()
            free_at = self._free_at.get(skill.name)
            if enforce and free_at is not None and now < free_at - 1e-3:
                return CloudDecision(False, SKIP_RATE)
            at = self.budget.take(requests, enforce)
            if at is None:
                return CloudDecision(False, SKIP_BUDGET)
            self._free_at[skill.name] = max(free_at or now, now) + requests * period
        return CloudDecision(True, meter=RunMeter(self, skill.name, requests, enforce, at))

    def charge_extra(self, skill: str, enforce: bool) -> bool:
        """One request beyond a run's reservation (a retry)."""
        if self.budget.take(1, enforce) is None:
            return False
        period = 1.0 / self.settings.max_cloud_rate_hz
        with self._lock:
            now = self._clock()
            self._free_at[skill] = max(self._free_at.get(skill, now), now) + period
        return True

    def release(self, skill: str, at: float, requests: int) -> None:
        self.budget.release(at, requests)
        with self._lock:
            if skill in self._free_at:
                self._free_at[skill] -= requests / self.settings.max_cloud_rate_hz

    def forget(self, skill_name: str) -> None:
        with self._lock:
            self._free_at.pop(skill_name, None)


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

    def put(
        self, skill: Skill, grounding: GroundingSource | GroundingResult, scene: Gate | None = None
    ) -> None:
        source = (
            grounding if isinstance(grounding, GroundingSource) else GroundingSource(grounding, 0)
        )
        with self._lock:
            self._expire()
            if len(self._entries) >= self._max_entries:
                oldest = min(self._entries, key=lambda k: self._entries[k].at)
                del self._entries[oldest]
            self._entries[grounding_key(skill)] = _Entry(self._clock(), source, scene)

    def get(self, skill: Skill, image: Image | None = None) -> GroundingResult | None:
        found = self.lookup(skill, image)
        return found.grounding if found is not None else None

    def lookup(self, skill: Skill, image: Image | None = None) -> GroundingSource | None:
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
            return entry.source

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
    source: GroundingSource
    scene: Gate | None
    """A frame-difference gate seeded with the frame the grounding was made on."""
