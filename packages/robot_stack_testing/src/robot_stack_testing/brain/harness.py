"""Test/benchmark helpers: the brain's executor, built by its composition root, on fakes at every
port (no network)."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pydantic import SecretStr

from robot_voice_chat.agent.executor import MissionExecutor
from robot_voice_chat.agent.memory import MemoryClient
from robot_voice_chat.agent.teaching import Teaching
from robot_voice_chat.agent.trace import TraceRecorder
from robot_voice_chat.composition import build_executor
from robot_voice_chat.control.approvals import ApprovalBroker
from robot_voice_chat.control.guard import GuardedToolBackend
from robot_voice_chat.control.latch import SafetyLatch
from robot_voice_chat.control.latch_store import LatchStore, MemoryLatchStore
from robot_voice_chat.control.policy import ToolPolicy
from robot_voice_chat.control.supervisor import MotionSupervisor
from robot_voice_chat.services.emitter.base import FakeEventEmitter
from robot_voice_chat.services.llm.fake import FakeLLM
from robot_voice_chat.services.speech.fake import FakeSpeechOutput
from robot_voice_chat.services.tools.fake import FakeToolBackend
from robot_voice_chat.settings import AgentConfig, McpServerConfig

NAV_SECRET = "nav-event-secret-for-tests-0123456789abcdef"  # noqa: S105 - test fixture
PERCEPTION_SECRET = "perception-event-secret-for-tests-0123456789"  # noqa: S105


def task_info(task_id: str, est: float = 20.0) -> str:
    return json.dumps({"task_id": task_id, "state": "running", "est_duration_s": est})


@dataclass
class Harness:
    executor: MissionExecutor
    planner: FakeLLM
    tools: FakeToolBackend
    emitter: FakeEventEmitter
    speech: FakeSpeechOutput
    trace: TraceRecorder
    teaching: Teaching
    latch: SafetyLatch
    supervisor: MotionSupervisor | None = None


def nav_servers() -> list[McpServerConfig]:
    return [
        McpServerConfig(
            name="navigation",
            url="http://127.0.0.1:9/sse",
            event_secret=SecretStr(NAV_SECRET),
            motion=True,
            safety_stop_tool="stop_navigation",
        ),
        McpServerConfig(name="memory", url="http://127.0.0.1:9/sse"),
        McpServerConfig(
            name="perception",
            url="http://127.0.0.1:9/sse",
            event_secret=SecretStr(PERCEPTION_SECRET),
        ),
    ]


def harness_tools() -> FakeToolBackend:
    """The fake servers of the harness: a navigation server whose drive never ends by itself
    and a perception server that prewarms."""
    tools = FakeToolBackend(nav_servers())
    tools.add("navigation.navigate_to", lambda a: task_info("nav-1"), location="string")
    tools.add("navigation.cancel_task", lambda a: {"cancelled": a["task_id"]}, task_id="string")
    tools.add("navigation.stop_navigation", lambda a: {"stopped": True})
    tools.add("navigation.list_tasks", lambda a: {"tasks": []}, states="array")
    tools.add("perception.prewarm", lambda a: {"ok": True}, query="string")
    tools.annotate("perception.prewarm", {"readOnlyHint": False, "destructiveHint": False})
    return tools


def make_harness(
    tmp_path: Path,
    planner: FakeLLM,
    *,
    memory_server: str = "",
    latch_store: LatchStore | None = None,
    policy: ToolPolicy | None = None,
    approvals: ApprovalBroker | None = None,
    emitter: FakeEventEmitter | None = None,
    trace: TraceRecorder | None = None,
    supervisor: tuple[float, float] | None = None,
    **agent: Any,
) -> Harness:
    """``supervisor``: (lease period, TTL) for a MotionSupervisor on the raw fake backend
    (start it with ``await h.supervisor.start()``); None: none."""
    tools = harness_tools()
    emitter, speech = emitter or FakeEventEmitter(), FakeSpeechOutput()
    trace = trace or TraceRecorder(tmp_path / "missions")
    latch = SafetyLatch(latch_store or MemoryLatchStore())
    leases = (
        MotionSupervisor(tools, latch, period_s=supervisor[0], ttl_s=supervisor[1])
        if supervisor is not None
        else None
    )
    executor = build_executor(
        AgentConfig(memory_server=memory_server, **agent),
        planner,
        GuardedToolBackend(tools, latch, policy, approvals),
        emitter,
        speech,
        trace,
        memory=MemoryClient(tools, memory_server),  # on the raw fakes, past the guard
        latch=latch,
        approvals=approvals,
        supervisor=leases,
    )
    return Harness(
        executor, planner, tools, emitter, speech, trace, executor.teaching, latch, leases
    )
