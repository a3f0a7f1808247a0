"""CostPolicy, CloudBudget and PrewarmCache with a fake clock (spec 000 §8)."""

from __future__ import annotations

from typing import Any

import numpy as np

from robot_mcp_perception.cost import (
    SKIP_BUDGET,
    SKIP_RATE,
    CloudBudget,
    CostPolicy,
    PrewarmCache,
    grounding_key,
)
from robot_mcp_perception.models.base import GroundingResult
from robot_mcp_perception.settings import CostSettings
from robot_mcp_perception.skills import Skill


class Clock:
    def __init__(self) -> None:
        self.now = 1000.0

    def __call__(self) -> float:
        return self.now


CONTINUOUS = Skill(name="scene", mode="describe", rate_hz=5.0)
ONCE = Skill(name="find", mode="describe", once=True)


def test_budget_window_slides_over_sixty_seconds() -> None:
    clock = Clock()
    budget = CloudBudget(2, clock)
    budget.record()
    budget.record()

    assert not budget.has_headroom()
    clock.now += 60.0
    assert budget.has_headroom()
    assert budget.total == 2


def test_per_skill_cloud_rate_is_capped() -> None:
    clock = Clock()
    policy = CostPolicy(CostSettings(max_cloud_rate_hz=1.0, max_cloud_calls_per_min=100), clock)
    assert policy.reserve(CONTINUOUS, 1).allowed

    clock.now += 0.5
    assert policy.reserve(CONTINUOUS, 1).reason == SKIP_RATE
    clock.now += 0.5
    assert policy.reserve(CONTINUOUS, 1).allowed


def test_the_per_skill_rate_meters_every_request_of_a_run() -> None:
    clock = Clock()
    policy = CostPolicy(CostSettings(max_cloud_rate_hz=2.0, max_cloud_calls_per_min=100), clock)
    assert policy.reserve(CONTINUOUS, 4).allowed  # e.g. four tile requests at once

    clock.now += 1.0
    assert policy.reserve(CONTINUOUS, 1).reason == SKIP_RATE  # 4 requests at 2 Hz = 2 s
    clock.now += 1.0
    assert policy.reserve(CONTINUOUS, 1).allowed


def test_a_run_reserves_all_its_requests_and_one_that_does_not_fit_is_skipped_whole() -> None:
    clock = Clock()
    policy = CostPolicy(CostSettings(max_cloud_calls_per_min=7, max_cloud_rate_hz=100.0), clock)
    assert policy.reserve(CONTINUOUS, 5).allowed
    assert policy.budget.used() == 5

    clock.now += 1.0
    decision = policy.reserve(CONTINUOUS, 5)
    assert (decision.allowed, decision.reason) == (False, SKIP_BUDGET)
    assert policy.budget.used() == 5  # nothing taken for the refused run
    assert policy.reserve(Skill(name="small", mode="describe"), 2).allowed


def test_budget_exhaustion_skips_continuous_but_not_once_skills() -> None:
    clock = Clock()
    policy = CostPolicy(CostSettings(max_cloud_calls_per_min=1, max_cloud_rate_hz=10.0), clock)
    assert policy.reserve(Skill(name="other", mode="describe"), 1).allowed

    assert policy.reserve(CONTINUOUS, 1).reason == SKIP_BUDGET
    assert policy.reserve(ONCE, 1).allowed
    assert policy.budget.used() == 2  # the once skill's request is counted too


def test_retries_beyond_the_reservation_are_charged_and_refused_once_the_budget_is_spent() -> None:
    clock = Clock()
    policy = CostPolicy(CostSettings(max_cloud_calls_per_min=3, max_cloud_rate_hz=100.0), clock)
    meter = policy.reserve(CONTINUOUS, 1).meter
    assert meter is not None

    assert [meter.charge() for _ in range(4)] == [True, True, True, False]
    assert meter.charged == 3
    assert policy.budget.used() == 3


def test_unused_reserved_requests_are_released_when_the_run_ends() -> None:
    clock = Clock()
    policy = CostPolicy(CostSettings(max_cloud_calls_per_min=10, max_cloud_rate_hz=1.0), clock)
    meter = policy.reserve(CONTINUOUS, 5).meter
    assert meter is not None
    assert meter.charge()
    meter.close()

    assert policy.budget.used() == 1
    assert policy.budget.total == 1
    clock.now += 1.0
    assert policy.reserve(CONTINUOUS, 1).allowed  # the rate follows the requests really sent


def test_gate_applies_to_continuous_skills_only_when_configured() -> None:
    gated = CostPolicy(CostSettings(cloud_requires_gate=True))
    ungated = CostPolicy(CostSettings(cloud_requires_gate=False))

    assert gated.needs_gate(CONTINUOUS)
    assert not gated.needs_gate(ONCE)
    assert not ungated.needs_gate(CONTINUOUS)
    assert ungated.needs_gate(CONTINUOUS, always_gated=True)


def test_forgetting_a_skill_clears_its_rate_history() -> None:
    clock = Clock()
    policy = CostPolicy(CostSettings(max_cloud_rate_hz=0.1), clock)
    assert policy.reserve(CONTINUOUS, 1).allowed
    policy.forget("scene")

    assert policy.reserve(CONTINUOUS, 1).allowed


def test_prewarm_cache_hits_within_ttl_and_expires_after() -> None:
    clock = Clock()
    cache = PrewarmCache(ttl_s=10.0, clock=clock)
    warm = Skill(name="warm", mode="ground_and_segment", grounding="The mug ", prewarm=True)
    later = Skill(name="grab", mode="ground_and_segment", grounding="the mug")
    grounding = GroundingResult(answer="mug")
    cache.put(warm, grounding)

    assert grounding_key(warm) == grounding_key(later)
    assert cache.get(later) is grounding
    assert cache.get(Skill(name="x", mode="region", grounding="the mug")) is None
    clock.now += 11.0
    assert cache.get(later) is None
    assert len(cache) == 0


class SceneGate:
    """Passes (= the scene differs) when the image's first pixel differs from the seed's."""

    def __init__(self) -> None:
        self.seed: int | None = None

    def passes(self, image: Any) -> bool:
        value = int(image[0, 0, 0])
        changed = value != self.seed
        self.seed = value
        return changed

    def reset(self) -> None:
        self.seed = None


def test_a_prewarm_entry_is_dropped_when_asked_on_a_frame_of_another_scene() -> None:
    cache = PrewarmCache(ttl_s=10.0)
    warm = Skill(name="warm", mode="ground_and_segment", grounding="mug", prewarm=True)
    grounding = GroundingResult(answer="mug")
    scene = SceneGate()
    scene.passes(np.zeros((4, 4, 3), np.uint8))  # seeded with the prewarm frame
    cache.put(warm, grounding, scene)

    assert cache.get(warm, np.zeros((4, 4, 3), np.uint8)) is grounding  # same scene
    assert cache.get(warm, np.full((4, 4, 3), 200, np.uint8)) is None  # another scene
    assert (cache.hits, cache.scene_changed, len(cache)) == (1, 1, 0)


def test_prewarm_cache_is_bounded() -> None:
    cache = PrewarmCache(ttl_s=100.0, max_entries=2)
    for index in range(5):
        cache.put(
            Skill(name=f"s{index}", mode="describe", grounding=f"g{index}"), GroundingResult()
        )

    assert len(cache) == 2
