"""Approvals in the executor: a confirm call waits in ``awaiting_approval`` for an operator's
yes, bound to that exact call; deny, timeout, changed arguments and replays never drive."""

from __future__ import annotations

import asyncio
import json
from pathlib import Path
from typing import Any

import pytest

from robot_stack_testing import async_wait_until
from robot_stack_testing.brain.harness import Harness, make_harness
from robot_voice_chat.agent.trace import TraceRecorder
from robot_voice_chat.control.approvals import ApprovalBroker, ApprovalRefusedError, parse_answer
from robot_voice_chat.control.policy import POLICY_DENIED, ToolPolicy
from robot_voice_chat.operator import acting_operator
from robot_voice_chat.services.emitter.base import FakeEventEmitter
from robot_voice_chat.services.llm.fake import FakeLLM, reply
from robot_voice_chat.socket_events import ApprovalRequested, ApprovalResolved

PLAN = reply(
    "",
    ("set_plan", {"steps": [{"id": "s1", "title": "Drive", "tool": "navigation.navigate_to"}]}),
    ("navigation.navigate_to", {"step_id": "s1", "location": "kitchen"}),
)
WAIT = reply("", ("wait_for_events", {"reason": "driving"}))
FINISH = reply("", ("finish_mission", {"outcome": "failed", "summary": "Not allowed."}))
CONFIRM_DRIVES = (
    "version: 1\ntools:\n  navigation.navigate_to: {decision: confirm, reason: drive}\n"
)


def harness(tmp_path: Path, planner: FakeLLM, timeout_s: float = 30.0) -> tuple[Harness, Path]:
    (tmp_path / "policy.yaml").write_text(CONFIRM_DRIVES)
    audit = tmp_path / "approvals.jsonl"
    emitter = FakeEventEmitter()
    trace = TraceRecorder(tmp_path / "missions")
    broker = ApprovalBroker(emitter=emitter, trace=trace, audit_path=audit, timeout_s=timeout_s)
    h = make_harness(
        tmp_path,
        planner,
        policy=ToolPolicy.load(tmp_path / "policy.yaml"),
        approvals=broker,
        emitter=emitter,
        trace=trace,
    )
    return h, audit


def requested(h: Harness) -> list[ApprovalRequested]:
    return [e for e in h.emitter.events if isinstance(e, ApprovalRequested)]


def resolved(h: Harness) -> list[ApprovalResolved]:
    return [e for e in h.emitter.events if isinstance(e, ApprovalResolved)]


async def waiting_for_approval(h: Harness) -> ApprovalRequested:
    await async_wait_until(lambda: requested(h), 5, "approval_requested")
    return requested(h)[-1]


def audit_lines(path: Path) -> list[dict[str, Any]]:
    return [json.loads(line) for line in path.read_text().splitlines()]


def broker_of(h: Harness) -> ApprovalBroker:
    assert h.executor.approvals is not None
    return h.executor.approvals


async def test_approve_sends_the_drive_and_audits_the_operator(tmp_path: Path) -> None:
    h, audit = harness(tmp_path, FakeLLM([PLAN, WAIT]))
    mission = await h.executor.start("go to the kitchen")
    request = await waiting_for_approval(h)

    assert mission.state == "awaiting_approval"
    assert h.tools.called("navigation.navigate_to") == []
    assert request.mission_id == mission.id
    assert request.step_id == "s1"
    assert request.tool == "navigation.navigate_to"
    assert request.arguments == {"location": "kitchen"}
    with acting_operator("alice"):
        broker_of(h).resolve(request.approval_id, "approve", "alice", "looks right")

    await async_wait_until(lambda: h.tools.called("navigation.navigate_to"), 5, "drive sent")
    assert h.tools.called("navigation.navigate_to") == [{"location": "kitchen"}]
    assert mission.state == "running"
    assert resolved(h)[-1].decision == "approve"
    assert resolved(h)[-1].operator == "alice"
    lines = audit_lines(audit)
    assert [line["event"] for line in lines] == ["approval_requested", "approval_resolved"]
    assert lines[1]["by"] == "alice"
    assert lines[1]["decision"] == "approve"
    await h.trace.flush()
    kinds = [r["kind"] for r in await h.trace.read(mission.id)]
    assert "approval_resolved" in kinds
    await h.executor.shutdown()


async def test_deny_never_sends_and_the_planner_reads_policy_denied(tmp_path: Path) -> None:
    planner = FakeLLM([PLAN, FINISH])
    h, _ = harness(tmp_path, planner)
    await h.executor.start("go to the kitchen")
    request = await waiting_for_approval(h)

    broker_of(h).resolve(request.approval_id, "deny", "bob", "wrong room")
    await h.executor.wait_idle(5)

    assert h.tools.called("navigation.navigate_to") == []
    answers = [r.content for m in planner.requests[-1][0] for r in m.tool_results]
    refusal = json.loads(answers[-1])
    assert refusal["error"] == POLICY_DENIED
    assert "wrong room" in refusal["detail"]


async def test_no_answer_within_the_timeout_denies(tmp_path: Path) -> None:
    planner = FakeLLM([PLAN, FINISH])
    h, audit = harness(tmp_path, planner, timeout_s=0.2)
    await h.executor.start("go to the kitchen")
    request = await waiting_for_approval(h)
    await h.executor.wait_idle(5)

    assert h.tools.called("navigation.navigate_to") == []
    assert resolved(h)[-1].decision == "deny"
    assert resolved(h)[-1].operator is None
    assert "no answer within 0.2 s" in resolved(h)[-1].reason
    with pytest.raises(ApprovalRefusedError) as late:
        broker_of(h).resolve(request.approval_id, "approve", "alice")
    assert late.value.status == 410
    assert audit_lines(audit)[-1]["decision"] == "deny"


async def test_an_approval_is_single_use_a_replay_is_refused(tmp_path: Path) -> None:
    h, _ = harness(tmp_path, FakeLLM([PLAN, WAIT]))
    await h.executor.start("go to the kitchen")
    request = await waiting_for_approval(h)
    broker_of(h).resolve(request.approval_id, "approve", "alice")
    await async_wait_until(lambda: h.tools.called("navigation.navigate_to"), 5, "drive sent")

    with pytest.raises(ApprovalRefusedError) as replay:
        broker_of(h).resolve(request.approval_id, "approve", "alice")
    assert replay.value.status == 409
    assert len(h.tools.called("navigation.navigate_to")) == 1
    await h.executor.shutdown()


async def test_an_approval_for_other_arguments_or_another_mission_is_refused(
    tmp_path: Path,
) -> None:
    h, _ = harness(tmp_path, FakeLLM([PLAN, WAIT]))
    mission = await h.executor.start("go to the kitchen")
    request = await waiting_for_approval(h)
    broker = broker_of(h)

    with pytest.raises(ApprovalRefusedError) as other_args:
        broker.resolve(request.approval_id, "approve", "a", arguments={"location": "roof"})
    with pytest.raises(ApprovalRefusedError) as other_mission:
        broker.resolve(request.approval_id, "approve", "a", mission_id="m-other")
    with pytest.raises(ApprovalRefusedError) as other_tool:
        broker.resolve(request.approval_id, "approve", "a", tool="navigation.spin")
    assert {e.value.status for e in (other_args, other_mission, other_tool)} == {409}
    assert h.tools.called("navigation.navigate_to") == []
    broker.resolve(
        request.approval_id,
        "approve",
        "a",
        tool="navigation.navigate_to",
        arguments={"location": "kitchen"},
        mission_id=mission.id,
    )
    await async_wait_until(lambda: h.tools.called("navigation.navigate_to"), 5, "drive sent")
    await h.executor.shutdown()


async def test_arguments_changed_after_the_approval_are_refused(tmp_path: Path) -> None:
    """The approval is redeemed against the call's arguments at the moment of sending."""
    h, _ = harness(tmp_path, FakeLLM([]))
    broker = broker_of(h)
    arguments: dict[str, Any] = {"location": "kitchen"}
    call = asyncio.create_task(h.executor.tools.call_tool("navigation.navigate_to", arguments))
    await async_wait_until(lambda: broker.pending(), 5, "pending approval")
    arguments["location"] = "roof"  # changed while the operator looked at "kitchen"
    broker.resolve(broker.pending()[0].approval_id, "approve", "alice")

    outcome = await call
    assert outcome.is_error
    assert json.loads(outcome.text)["error"] == POLICY_DENIED
    assert "changed" in json.loads(outcome.text)["detail"]
    assert h.tools.called("navigation.navigate_to") == []


async def test_unknown_approvals_are_refused(tmp_path: Path) -> None:
    h, _ = harness(tmp_path, FakeLLM([]))
    with pytest.raises(ApprovalRefusedError) as unknown:
        broker_of(h).resolve("ap-nope", "approve", "alice")
    assert unknown.value.status == 404


async def test_a_typed_yes_approves_and_a_vague_answer_does_not(tmp_path: Path) -> None:
    h, _ = harness(tmp_path, FakeLLM([PLAN, WAIT]))
    await h.executor.start("go to the kitchen")
    await waiting_for_approval(h)

    await h.executor.on_user_turn("sure, maybe")
    await asyncio.sleep(0)
    assert h.tools.called("navigation.navigate_to") == []
    assert "Please answer yes or no" in h.speech.spoken[-1]
    with acting_operator("carol"):
        await h.executor.on_user_turn("Yes!")

    await async_wait_until(lambda: h.tools.called("navigation.navigate_to"), 5, "drive sent")
    assert resolved(h)[-1].operator == "carol"
    await h.executor.shutdown()


async def test_a_typed_no_denies(tmp_path: Path) -> None:
    h, _ = harness(tmp_path, FakeLLM([PLAN, FINISH]))
    await h.executor.start("go to the kitchen")
    await waiting_for_approval(h)
    await h.executor.on_user_turn("no")
    await h.executor.wait_idle(5)
    assert h.tools.called("navigation.navigate_to") == []
    assert resolved(h)[-1].decision == "deny"


async def test_a_safety_stop_denies_the_pending_approval(tmp_path: Path) -> None:
    h, _ = harness(tmp_path, FakeLLM([PLAN, WAIT]))
    mission = await h.executor.start("go to the kitchen")
    request = await waiting_for_approval(h)
    await h.executor.on_user_turn("stop")

    await async_wait_until(lambda: resolved(h), 5, "approval_resolved")
    assert resolved(h)[-1].decision == "deny"
    assert "safety stop" in resolved(h)[-1].reason
    with pytest.raises(ApprovalRefusedError):
        broker_of(h).resolve(request.approval_id, "approve", "alice")
    assert h.tools.called("navigation.navigate_to") == []
    assert mission.state == "paused"
    await h.executor.shutdown()


@pytest.mark.parametrize(
    ("text", "verdict"),
    [
        ("yes", "approve"),
        ("Yes, please.", "approve"),
        ("approve", "approve"),
        ("no", "deny"),
        ("Don't!", "deny"),
        ("yes but not there", None),
        ("ok", None),
        ("maybe", None),
        ("", None),
    ],
)
def test_only_explicit_answers_count(text: str, verdict: str | None) -> None:
    assert parse_answer(text) == verdict


async def test_a_decision_without_a_reason_says_who_decided(tmp_path: Path) -> None:
    h, _ = harness(tmp_path, FakeLLM([PLAN, FINISH]))
    await h.executor.start("go to the kitchen")
    request = await waiting_for_approval(h)
    broker_of(h).resolve(request.approval_id, "deny", "bob")
    await h.executor.wait_idle(5)
    assert resolved(h)[-1].reason == "denied by bob"
