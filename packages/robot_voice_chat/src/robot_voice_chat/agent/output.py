"""What a mission shows and says: plan snapshots, event lines and speech (all traced)."""

from __future__ import annotations

import time

from robot_voice_chat.agent.run import MissionRun
from robot_voice_chat.agent.trace import TraceRecorder
from robot_voice_chat.services.emitter.base import EventEmitter
from robot_voice_chat.services.speech.base import SpeechOutput
from robot_voice_chat.socket_events import MissionEventLine


class MissionOutput:
    def __init__(self, emitter: EventEmitter, speech: SpeechOutput, trace: TraceRecorder) -> None:
        self.emitter = emitter
        self.speech = speech
        self.trace = trace

    async def emit_plan(self, run: MissionRun) -> None:
        snapshot = run.mission.snapshot()
        self.trace.record(run.mission.id, "plan", plan=snapshot.model_dump(mode="json"))
        await self.emitter.emit(snapshot)

    async def say(self, run: MissionRun, text: str) -> None:
        await self.log_line(run, "say", text)
        await self.speech.say(text)

    async def log_line(self, run: MissionRun, kind: str, text: str) -> None:
        await self.emitter.emit(
            MissionEventLine(mission_id=run.mission.id, kind=kind, text=text, ts=time.time())
        )
