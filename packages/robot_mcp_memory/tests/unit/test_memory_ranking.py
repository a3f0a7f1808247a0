import pytest

from robot_mcp_memory.ranking import outcome_boost, rank, success_rate
from robot_mcp_memory.store.base import Candidate, OutcomeStats, StoredProcess


def candidate(
    process_id: str, relevance: float, successes: int = 0, failures: int = 0
) -> Candidate:
    process = StoredProcess(
        id=process_id,
        version=1,
        current_version=1,
        title=process_id,
        task_pattern="",
        tags=(),
        markdown="",
        created_at=0.0,
        saved_by="robot-1",
        stats=OutcomeStats(successes=successes, failures=failures),
    )
    return Candidate(process=process, relevance=relevance)


def test_no_outcomes_leave_the_text_score_unchanged() -> None:
    assert success_rate(OutcomeStats()) == 0.5
    assert outcome_boost(OutcomeStats()) == 1.0


def test_the_boost_follows_the_documented_formula() -> None:
    assert outcome_boost(OutcomeStats(successes=1)) == pytest.approx(1 + 1 / 6)
    assert outcome_boost(OutcomeStats(failures=1)) == pytest.approx(1 - 1 / 6)
    assert outcome_boost(OutcomeStats(failures=10)) == pytest.approx(1 + 0.5 * (2 / 12 - 1))
    assert outcome_boost(OutcomeStats(failures=3), weight=0.0) == 1.0


def test_the_boost_stays_within_its_bounds() -> None:
    assert 0.5 < outcome_boost(OutcomeStats(failures=10_000)) < 0.5001
    assert 1.4999 < outcome_boost(OutcomeStats(successes=10_000)) < 1.5


def test_an_out_of_range_weight_is_refused() -> None:
    with pytest.raises(ValueError, match="outcome weight"):
        outcome_boost(OutcomeStats(), weight=2.0)


def test_failures_push_a_close_match_below_a_successful_one() -> None:
    before = rank([candidate("a", 10.0), candidate("b", 9.0)])
    after = rank([candidate("a", 10.0, failures=2), candidate("b", 9.0, successes=1)])

    assert [item.candidate.process.id for item in before] == ["a", "b"]
    assert [item.candidate.process.id for item in after] == ["b", "a"]
    assert after[0].score == pytest.approx(9.0 * (1 + 1 / 6))


def test_outcomes_do_not_lift_an_unrelated_document_over_a_strong_match() -> None:
    ranked = rank([candidate("strong", 10.0, failures=20), candidate("weak", 2.0, successes=20)])

    assert ranked[0].candidate.process.id == "strong"


def test_ties_are_broken_by_id() -> None:
    ranked = rank([candidate("b", 1.0), candidate("a", 1.0)])

    assert [item.candidate.process.id for item in ranked] == ["a", "b"]


def test_replacement_relevances_must_match_the_candidates() -> None:
    ranked = rank([candidate("a", 1.0), candidate("b", 2.0)], relevances=[0.9, 0.1])

    assert ranked[0].candidate.process.id == "a"
    with pytest.raises(ValueError, match="one entry per candidate"):
        rank([candidate("a", 1.0)], relevances=[])
