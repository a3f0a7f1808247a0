from __future__ import annotations

import json
from typing import Any

import pytest
from hypothesis import given
from hypothesis import strategies as st
from pydantic import ValidationError

from robot_mcp_kit.models import (
    EVENT_TYPES,
    SCHEMA_VERSION,
    TaskEvent,
    TaskFailure,
    TaskInfo,
)

json_values = st.recursive(
    st.none() | st.booleans() | st.integers(-(2**53), 2**53) | st.text(max_size=20),
    lambda children: (
        st.lists(children, max_size=4) | st.dictionaries(st.text(max_size=8), children, max_size=4)
    ),
    max_leaves=12,
)
payloads = st.dictionaries(st.text(max_size=10), json_values, max_size=5)


@given(
    task_id=st.text(min_size=1, max_size=30),
    type_=st.sampled_from([t for t in EVENT_TYPES if t != "task_failed"]),
    seq=st.integers(0, 2**40),
    ts=st.floats(0, 4e9, allow_nan=False),
    payload=payloads,
)
def test_task_events_survive_a_json_round_trip(
    task_id: str, type_: Any, seq: int, ts: float, payload: dict[str, Any]
) -> None:
    event = TaskEvent(
        task_id=task_id,
        server="nav",
        tool="navigate_to",
        type=type_,
        seq=seq,
        ts=ts,
        payload=payload,
    )
    assert TaskEvent.model_validate_json(event.model_dump_json()) == event


def test_a_new_event_gets_the_schema_version_a_fresh_id_and_a_timestamp() -> None:
    a = TaskEvent(task_id="t", server="s", tool="x", type="progress", seq=0)
    b = TaskEvent(task_id="t", server="s", tool="x", type="progress", seq=0)
    assert a.schema_version == SCHEMA_VERSION == 1
    assert a.event_id != b.event_id
    assert len(a.event_id) == 32
    assert a.ts > 1_600_000_000
    assert set(json.loads(a.model_dump_json())) == {
        "schema_version",
        "event_id",
        "task_id",
        "server",
        "tool",
        "type",
        "seq",
        "ts",
        "payload",
    }


def test_events_are_frozen() -> None:
    event = TaskEvent(task_id="t", server="s", tool="x", type="progress", seq=0)
    with pytest.raises(ValidationError):
        event.seq = 3  # type: ignore[misc]


@pytest.mark.parametrize(
    "change",
    [{"type": "finished"}, {"seq": -1}, {"task_id": ""}, {"server": ""}],
)
def test_malformed_events_are_rejected(change: dict[str, Any]) -> None:
    fields: dict[str, Any] = {"task_id": "t", "server": "s", "tool": "x", "type": "progress"}
    fields["seq"] = 0
    with pytest.raises(ValidationError):
        TaskEvent(**{**fields, **change})


def test_a_task_failed_event_must_carry_a_task_failure() -> None:
    failure = TaskFailure(error_code="DOOR_CLOSED", message="closed", suggestions=["wait"])
    event = TaskEvent(
        task_id="t",
        server="s",
        tool="x",
        type="task_failed",
        seq=2,
        payload={**failure.model_dump(), "pose": {"x": 1}},
    )
    assert event.failure() == failure
    assert event.terminal
    with pytest.raises(ValidationError, match="error_code"):
        TaskEvent(task_id="t", server="s", tool="x", type="task_failed", seq=2, payload={})


def test_only_task_failed_events_have_a_failure() -> None:
    event = TaskEvent(task_id="t", server="s", tool="x", type="task_done", seq=0)
    assert event.failure() is None
    assert event.terminal
    assert not TaskEvent(task_id="t", server="s", tool="x", type="watch_event", seq=0).terminal


def test_task_failure_defaults_match_the_contract() -> None:
    failure = TaskFailure(error_code="E", message="m")
    assert failure.recoverable is False
    assert failure.suggestions == []


def test_task_info_json_keeps_extra_fields_and_round_trips() -> None:
    info = TaskInfo(task_id="nav-1", est_duration_s=12.5, destination="kitchen")
    data = json.loads(info.to_json())
    assert data == {
        "task_id": "nav-1",
        "state": "running",
        "est_duration_s": 12.5,
        "server": None,
        "tool": None,
        "destination": "kitchen",
    }
    assert TaskInfo.model_validate_json(info.to_json()) == info
    with pytest.raises(ValidationError):
        TaskInfo(task_id="nav-1", state="paused")
