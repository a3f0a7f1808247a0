"""Missions a previous process life left live (issue 23 item 3): after a crash (kill -9) the
archive still says ``running``. At start-up each is closed as failed, "interrupted by a
restart", its steps resolved, the trace and the UI told; the task ids it owned are returned so
that reconciliation cancels them at their servers and their late events are acknowledged as
such, never taken for live ones."""

from __future__ import annotations

import time

import structlog

from robot_voice_chat.agent.archive import MissionArchive
from robot_voice_chat.agent.mission import Mission, now
from robot_voice_chat.agent.trace import TraceRecorder
from robot_voice_chat.services.emitter.base import EventEmitter
from robot_voice_chat.services.speech.base import SpeechOutput
from robot_voice_chat.socket_events import MissionEventLine, MissionFinished

logger = structlog.get_logger(__name__)
INTERRUPTED = "interrupted by a restart"
# No claim about its tasks: whether a drive had ended or is still going is only known when
# its server answers (reconciliation stops what still runs, and says so).
SUMMARY = (
    "The mission was interrupted by a restart of the brain. Give the instruction again to carry on."
)


def stopped_after_restart(server: str) -> str:
    what = "drive" if server == "navigation" else "movement"
    return f"I stopped the {what} that the mission interrupted by my restart had left running."


def close(mission: Mission) -> set[str]:
    """Resolve the mission's state and steps in place; the task ids it had running."""
    owned = {s.task_id for s in mission.steps if s.status == "running" and s.task_id}
    for step in mission.steps:
        if step.status == "pending":
            step.set_status("skipped", "never run")
        elif step.status == "running":
            step.set_status("failed", INTERRUPTED)
    mission.state = "failed"
    mission.summary = SUMMARY
    mission.ended_at = now()
    return owned


async def close_interrupted(
    archive: MissionArchive, trace: TraceRecorder, emitter: EventEmitter, speech: SpeechOutput
) -> set[str]:
    """Close every mission the archive holds as live (told on screen and said, as a
    finished mission's summary is); the task ids they owned."""
    started = time.monotonic()
    owned: set[str] = set()
    missions = await archive.live()
    for mission in missions:
        tasks = close(mission)
        owned |= tasks
        await archive.save(mission)
        line = MissionEventLine(mission_id=mission.id, kind="say", text=SUMMARY, ts=time.time())
        await archive.append_event(line)
        trace.record(
            mission.id,
            "final",
            outcome="failed",
            summary=SUMMARY,
            reason=INTERRUPTED,
            tasks=sorted(tasks),
        )
        await emitter.emit(mission.snapshot())
        await emitter.emit(line)
        await emitter.emit(
            MissionFinished(mission_id=mission.id, outcome="failed", summary=SUMMARY)
        )
        await speech.say(SUMMARY)
        logger.warning(
            "mission_interrupted", mission_id=mission.id, reason=INTERRUPTED, tasks=sorted(tasks)
        )
    await trace.flush()
    if missions:
        logger.info(
            "interrupted_missions_closed",
            count=len(missions),
            duration_ms=round((time.monotonic() - started) * 1000, 1),
        )
    return owned
