"""Ranking: text relevance adjusted by recorded outcomes.

For a candidate with text relevance ``r`` (from the store, higher is better) and outcomes
recorded against its current version — ``s_r`` successes / ``f_r`` failures by this robot,
``s_o`` / ``f_o`` by the other robots of the fleet::

    s     = k · s_r + s_o,  f = k · f_r + f_o   # this robot's outcomes count k times (default 3)
    p     = (s + 1) / (s + f + 2)          # Laplace-smoothed success rate; 0.5 with no outcomes
    boost = 1 + w · (2p − 1)               # in [1 − w, 1 + w]; exactly 1 with no outcomes
    score = r · boost

So a success on this robot lifts a process more than a success elsewhere in the fleet, which
still lifts it above one nobody has tried (``k`` is ``MEMORY_ROBOT_OUTCOME_FACTOR``).

``w`` is the outcome weight (default 0.5, setting ``MEMORY_OUTCOME_WEIGHT``): one success lifts a
process by a sixth, one failure lowers it by a sixth, and ten failures leave it at
about 0.58 of its text score — outcomes reorder close matches, they never make an unrelated
document win. A new version starts with no outcomes. When the optional embedding re-ranker is
on, ``r`` is its blended relevance (see :mod:`robot_mcp_memory.embeddings`).
"""

from __future__ import annotations

from dataclasses import dataclass

from robot_mcp_memory.store.base import Candidate, OutcomeStats

DEFAULT_OUTCOME_WEIGHT = 0.5
DEFAULT_ROBOT_FACTOR = 3.0


@dataclass(frozen=True)
class Ranked:
    candidate: Candidate
    relevance: float
    boost: float

    @property
    def score(self) -> float:
        return self.relevance * self.boost


def success_rate(
    stats: OutcomeStats,
    robot_stats: OutcomeStats | None = None,
    robot_factor: float = DEFAULT_ROBOT_FACTOR,
) -> float:
    """Laplace-smoothed success rate (0.5 with no outcomes). ``stats`` are the fleet's counts
    (this robot's included), ``robot_stats`` this robot's share, weighted ``robot_factor``."""
    mine = robot_stats or OutcomeStats()
    successes = stats.successes + (robot_factor - 1.0) * mine.successes
    failures = stats.failures + (robot_factor - 1.0) * mine.failures
    return (successes + 1) / (successes + failures + 2)


def outcome_boost(
    stats: OutcomeStats,
    weight: float = DEFAULT_OUTCOME_WEIGHT,
    robot_stats: OutcomeStats | None = None,
    robot_factor: float = DEFAULT_ROBOT_FACTOR,
) -> float:
    """Multiplier in [1 − weight, 1 + weight] from the recorded outcomes."""
    if not 0.0 <= weight <= 1.0:
        raise ValueError(f"outcome weight must be within [0, 1], got {weight}")
    if robot_factor < 1.0:
        raise ValueError(f"robot outcome factor must be ≥ 1, got {robot_factor}")
    return 1.0 + weight * (2.0 * success_rate(stats, robot_stats, robot_factor) - 1.0)


def rank(
    candidates: list[Candidate],
    *,
    outcome_weight: float = DEFAULT_OUTCOME_WEIGHT,
    relevances: list[float] | None = None,
    robot_factor: float = DEFAULT_ROBOT_FACTOR,
) -> list[Ranked]:
    """Candidates ordered by ``relevance × outcome boost`` (ties: higher text relevance, then id).

    ``relevances`` replaces the candidates' own text relevance (same order), e.g. with the
    embedding re-ranker's blend.
    """
    if relevances is not None and len(relevances) != len(candidates):
        raise ValueError("relevances must have one entry per candidate")
    ranked = [
        Ranked(
            candidate=candidate,
            relevance=candidate.relevance if relevances is None else relevances[index],
            boost=outcome_boost(
                candidate.process.stats,
                outcome_weight,
                candidate.process.robot_stats,
                robot_factor,
            ),
        )
        for index, candidate in enumerate(candidates)
    ]
    ranked.sort(
        key=lambda item: (-item.score, -item.candidate.relevance, item.candidate.process.id)
    )
    return ranked
