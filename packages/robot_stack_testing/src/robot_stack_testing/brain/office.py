"""The simulated office with the brain on it (tests, benchmarks): the executor on the rules
planner, built by the brain's composition root, over the office's fake servers
(``office_world.py``) and, when asked, its arm (``office_arm.py``)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from robot_stack_testing.brain.harness import nav_servers
from robot_stack_testing.brain.office_arm import OfficeArm, arm_server
from robot_stack_testing.brain.office_world import OfficeWorld
from robot_voice_chat.agent.executor import MissionExecutor
from robot_voice_chat.agent.mission import Mission
from robot_voice_chat.agent.trace import TraceRecorder
from robot_voice_chat.composition import build_executor
from robot_voice_chat.services.emitter.base import FakeEventEmitter
from robot_voice_chat.services.llm.rules.planner import RulesPlanner
from robot_voice_chat.services.speech.fake import FakeSpeechOutput
from robot_voice_chat.services.tools.fake import FakeToolBackend
from robot_voice_chat.settings import AgentConfig


@dataclass
class Office:
    executor: MissionExecutor
    world: OfficeWorld
    tools: FakeToolBackend
    emitter: FakeEventEmitter
    speech: FakeSpeechOutput
    trace: TraceRecorder

    async def run(self, instruction: str, timeout_s: float = 10.0) -> Mission:
        mission = await self.executor.start(instruction)
        await self.executor.wait_idle(timeout_s)
        return mission

    def statuses(self, mission: Mission) -> dict[str, str]:
        return {s.id: s.status for s in mission.steps}


def office(tmp_path: Path, drive_s: float = 0.05, arm: bool = False, **agent: Any) -> Office:
    """An executor on the rules planner in the simulated office (swap ``executor.planner``);
    ``arm``: the robot has one (the manipulation server's tools, office_arm.py)."""
    tools = FakeToolBackend(nav_servers() + ([arm_server()] if arm else []))
    world = OfficeWorld(tools, drive_s=drive_s)
    if arm:
        world.arm = OfficeArm(world)
    emitter, speech = FakeEventEmitter(), FakeSpeechOutput()
    trace = TraceRecorder(tmp_path / "missions")
    executor = build_executor(
        AgentConfig(memory_server="", **agent), RulesPlanner(), tools, emitter, speech, trace
    )
    world.deliver = executor.on_task_event
    return Office(executor, world, tools, emitter, speech, trace)
