"""What a mission shows and says: plan snapshots, event lines and speech (all traced)."""

from __future__ import annotations

import time
from typing import Any

from robot_voice_chat.agent.archive import MissionArchive
from robot_voice_chat.agent.mission import Mission, PlanStep
from robot_voice_chat.agent.run import MissionRun
from robot_voice_chat.agent.trace import TraceRecorder
from robot_voice_chat.services.emitter.base import EventEmitter
from robot_voice_chat.services.speech.base import SpeechOutput
from robot_voice_chat.socket_events import MissionEventLine


class MissionOutput:
    def __init__(
        self,
        emitter: EventEmitter,
        speech: SpeechOutput,
        trace: TraceRecorder,
        archive: MissionArchive | None = None,
    ) -> None:
        self.emitter = emitter
        self.speech = speech
        self.trace = trace
        self.archive = archive

    async def emit_plan(self, run: MissionRun) -> None:
        mission = run.mission
        snapshot = mission.snapshot()
        self.trace.record(
            mission.id,
            "plan",
            plan=snapshot.model_dump(mode="json"),
            timings=[step_timing(s) for s in mission.steps],
        )
        await self.emitter.emit(snapshot)
        await self.save(mission)

    async def save(self, mission: Mission) -> None:
        if self.archive is not None:
            await self.archive.save(mission)

    async def say(self, run: MissionRun, text: str) -> None:
        self.trace.record(run.mission.id, "say", text=text)
        await self.log_line(run, "say", text)
        await self.speech.say(text)

    async def log_line(self, run: MissionRun, kind: str, text: str) -> None:
        line = MissionEventLine(mission_id=run.mission.id, kind=kind, text=text, ts=time.time())
        await self.emitter.emit(line)
        if self.archive is not None:
            await self.archive.append_event(line)


def step_timing(step: PlanStep) -> dict[str, Any]:
    """When a step ran and for how long (None while it has not started/ended)."""
    duration_ms = None
    if step.started_at is not None and step.ended_at is not None:
        duration_ms = round((step.ended_at - step.started_at).total_seconds() * 1000, 1)
    return {
        "id": step.id,
        "status": step.status,
        "started_at": step.started_at.isoformat() if step.started_at else None,
        "ended_at": step.ended_at.isoformat() if step.ended_at else None,
        "duration_ms": duration_ms,
    }
