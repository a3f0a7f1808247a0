"""What ``/healthz`` reports: the node's real state, and whether it is degraded (HTTP 503).

Degraded when no camera frame arrived yet or the newest is older than
``node.frame_stale_after_s``, when a model adapter says it cannot answer (e.g. its key was
refused), or when the model loop is not running. Per-skill failures are reported but do not
make the node degraded: one bad skill does not stop the others.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

from robot_mcp_perception.cost import CostPolicy
from robot_mcp_perception.frames import FrameSource
from robot_mcp_perception.models.base import Grounder, Segmenter
from robot_mcp_perception.registry import SkillRegistry, SkillState
from robot_mcp_perception.scheduler import Scheduler


@dataclass
class HealthSources:
    node_name: str
    started: float
    frame_stale_after_s: float
    frame_source: FrameSource
    grounder: Grounder
    segmenter: Segmenter
    scheduler: Scheduler
    policy: CostPolicy
    registry: SkillRegistry


def health_report(sources: HealthSources) -> dict[str, Any]:
    now = time.monotonic()
    problems: list[str] = []
    frame = sources.frame_source.latest()
    age = sources.frame_source.latest_age_s()
    if frame is None or age is None:
        problems.append("no camera frame received yet")
    elif age > sources.frame_stale_after_s:
        problems.append(f"the newest camera frame arrived {age:.1f} s ago")
    models = {}
    for role, model in (("grounder", sources.grounder), ("segmenter", sources.segmenter)):
        problem = model.readiness()
        models[role] = {
            "adapter": type(model).__name__,
            "cost_class": model.cost_class,
            "ready": problem is None,
            "problem": problem,
        }
        if problem is not None:
            problems.append(f"{role}: {problem}")
    if not sources.scheduler.alive:
        problems.append("the model loop is not running")
    return {
        "status": "degraded" if problems else "ok",
        "problems": problems,
        "node": sources.node_name,
        "uptime_s": round(now - sources.started, 3),
        "frame": {
            "age_s": round(age, 3) if age is not None else None,
            "seq": frame.seq if frame else None,
            "stamp_ns": frame.stamp_ns if frame else None,
        },
        "models": models,
        "model_loop": {
            "running": sources.scheduler.alive,
            "in_flight": sources.scheduler.in_flight,
        },
        "cloud_calls_last_min": sources.policy.budget.used(),
        "cloud_budget_per_min": sources.policy.budget.max_per_min,
        "skills": [_skill(state, now) for state in sources.registry.states()],
    }


def _skill(state: SkillState, now: float) -> dict[str, Any]:
    last = state.last_publish_wall
    return {
        "name": state.skill.name,
        "mode": state.skill.mode,
        "enabled": state.enabled,
        "runs": state.runs,
        "published": state.published,
        "failures": state.failures,
        "consecutive_failures": state.consecutive_failures,
        "last_error": state.last_error,
        "last_publish_age_s": round(now - last, 3) if last is not None else None,
    }
