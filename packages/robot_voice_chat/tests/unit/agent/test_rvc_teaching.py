"""Teaching (spec §8): transcript, distillation, save_process, failures never break finalization."""

from __future__ import annotations

import asyncio
from pathlib import Path
from typing import Any

from robot_stack_testing import async_wait_until
from robot_stack_testing.brain.harness import Harness, make_harness
from robot_voice_chat.agent.teaching import render_transcript
from robot_voice_chat.agent.trace import TraceRecorder
from robot_voice_chat.control.approvals import ApprovalBroker
from robot_voice_chat.control.policy import ToolPolicy
from robot_voice_chat.pipeline.chat import ChatPipeline
from robot_voice_chat.services.emitter.base import FakeEventEmitter
from robot_voice_chat.services.llm.base import LLMError
from robot_voice_chat.services.llm.fake import FakeLLM, reply
from robot_voice_chat.settings import CONFIG_DIR, ChatConfig
from robot_voice_chat.socket_events import (
    ApprovalRequested,
    TeachingFailed,
    TeachingSaved,
    TeachingState,
)

DOC = (
    "---\nid: mailroom-fetch\ntitle: Fetch\ntask_pattern: fetch\ntags: [mail]\n---\n## Steps\n1. go"
)


def mission_script() -> list[object]:
    return [
        reply("", ("navigation.lookup", {"where": "mailroom"})),
        reply("", ("finish_mission", {"outcome": "succeeded", "summary": "Fetched it."})),
    ]


async def test_armed_teaching_distills_the_trace_and_saves_the_process(tmp_path: Path) -> None:
    planner = FakeLLM([*mission_script(), reply(DOC)])  # type: ignore[list-item]
    h = make_harness(tmp_path, planner, memory_server="memory")
    h.tools.add("navigation.lookup", lambda a: (_ for _ in ()).throw(ValueError("DOOR_CLOSED")))
    h.tools.add(
        "memory.find_processes",
        lambda a: {"processes": [{"id": "old", "title": "Old", "score": 0.9, "markdown": "x"}]},
    )
    h.tools.add("memory.save_process", lambda a: {"id": "mailroom-fetch"})
    h.tools.add("memory.record_outcome", lambda a: {"ok": True})
    await h.teaching.arm(True)

    mission = await h.executor.start("fetch the package from the mailroom")
    await h.executor.wait_idle(5)
    await _until_idle(h)

    assert mission.teaching
    prompt = planner.requests[-1][0]
    assert "robot-mcp-memory doc format" in prompt[0].content
    assert "CALL navigation.lookup" in prompt[1].content
    assert "ERROR: DOOR_CLOSED" in prompt[1].content
    assert h.tools.called("memory.save_process") == [{"markdown": DOC}]
    assert any(
        isinstance(e, TeachingSaved) and e.process_id == "mailroom-fetch" for e in h.emitter.events
    )
    assert h.tools.called("memory.record_outcome") == [
        {"process_id": "old", "success": True, "note": "Fetched it."}
    ]
    assert "Past process documents follow" in planner.requests[0][0][0].content
    assert not h.teaching.armed
    assert TeachingState(armed=False) in h.emitter.events


async def test_distillation_failure_is_reported_and_finalization_still_completes(
    tmp_path: Path,
) -> None:
    planner = FakeLLM([*mission_script(), LLMError("rate limited")])  # type: ignore[list-item]
    h = make_harness(tmp_path, planner, memory_server="memory")
    h.tools.add("navigation.lookup", lambda a: "ok")
    await h.teaching.arm(True)
    mission = await h.executor.start("fetch")
    await h.executor.wait_idle(5)
    await _until_idle(h)
    assert mission.state == "succeeded"
    assert any(isinstance(e, TeachingFailed) for e in h.emitter.events)
    assert h.executor.active is None


def test_transcript_drops_progress_and_keeps_user_corrections() -> None:
    trace: list[dict[str, Any]] = [
        {"kind": "instruction", "instruction": "fetch"},
        {"kind": "task_event", "type": "progress", "text": None},
        {"kind": "user_turn", "text": "use the side door"},
        {
            "kind": "tool_result",
            "tool": "nav.go",
            "arguments": {"a": 1},
            "result": "ok",
            "is_error": False,
        },
    ]
    text = render_transcript(trace)
    assert "progress" not in text
    assert "USER: use the side door" in text
    assert 'CALL nav.go({"a":1}) -> ok: ok' in text


async def _until_idle(h: Harness) -> None:
    def done() -> bool:
        return any(isinstance(e, TeachingSaved | TeachingFailed) for e in h.emitter.events)

    await async_wait_until(done, 5, "teaching finished")


def shipped_policy_harness(tmp_path: Path, planner: FakeLLM) -> Harness:
    emitter, trace = FakeEventEmitter(), TraceRecorder(tmp_path / "missions")
    broker = ApprovalBroker(
        emitter=emitter, trace=trace, audit_path=tmp_path / "approvals.jsonl", timeout_s=30
    )
    h = make_harness(
        tmp_path,
        planner,
        memory_server="memory",
        policy=ToolPolicy.load(CONFIG_DIR / "policy.yaml"),
        approvals=broker,
        emitter=emitter,
        trace=trace,
    )
    h.tools.add("memory.save_process", lambda a: {"id": "taught"}, markdown="string")
    h.tools.add("memory.find_processes", lambda a: {"processes": []}, query="string", k="integer")
    h.tools.add("memory.record_outcome", lambda a: {"ok": True}, process_id="string")
    return h


async def test_the_fast_path_cannot_store_a_process_without_an_operators_yes(
    tmp_path: Path,
) -> None:
    """Issue 31: the fast path called memory.save_process and it was stored, no approval."""
    h = shipped_policy_harness(tmp_path, FakeLLM([]))
    injected = "---\nid: open-all-doors\ntitle: x\ntask_pattern: any\ntags: []\n---\n## Steps\n1."
    fast = FakeLLM([reply("", ("memory.save_process", {"markdown": injected})), reply("ok")])
    pipeline = ChatPipeline(
        llm=fast,
        tools=h.executor.tools,
        executor=h.executor,
        emitter=h.emitter,
        speech=h.speech,
        config=ChatConfig(),
    )
    turn = asyncio.create_task(pipeline.handle_turn("remember this process"))
    await async_wait_until(
        lambda: [e for e in h.emitter.events if isinstance(e, ApprovalRequested)],
        5,
        "the approval card",
    )
    assert h.tools.called("memory.save_process") == []  # not before a yes
    assert h.executor.approvals is not None
    [pending] = h.executor.approvals.pending(None)
    h.executor.approvals.resolve(pending.approval_id, "deny", "alice")
    await asyncio.wait_for(turn, 5)
    assert h.tools.called("memory.save_process") == []


async def test_teaching_the_operator_armed_stores_its_process_under_the_shipped_policy(
    tmp_path: Path,
) -> None:
    planner = FakeLLM(
        [reply("", ("finish_mission", {"outcome": "succeeded", "summary": "Done."})), reply(DOC)]
    )
    h = shipped_policy_harness(tmp_path, planner)
    await h.teaching.arm(True)
    await h.executor.start("fetch the package from the mailroom")
    await h.executor.wait_idle(5)
    await _until_idle(h)
    assert h.tools.called("memory.save_process") == [{"markdown": DOC}]
    assert not [e for e in h.emitter.events if isinstance(e, ApprovalRequested)]
