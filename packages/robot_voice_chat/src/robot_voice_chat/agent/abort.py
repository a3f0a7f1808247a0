"""Abort (issue 39 item 4): "abort", "cancel", "never mind" end a running mission at once.

No planner in the path, as for a stop (bargein.py): the mission is marked finished (the loop
ends and every later turn is a new request), its planner step is cancelled and its live tasks
are cancelled on the servers that own them, so a drive stops at once. A paused mission
(after a stop) keeps its own "continue or abort?" answer, which the planner handles.
"""

from __future__ import annotations

import asyncio
import re

import structlog

from robot_voice_chat.agent.dispatch import TaskDispatcher
from robot_voice_chat.agent.mission import Mission
from robot_voice_chat.agent.run import MissionRun
from robot_voice_chat.agent.task_registry import TaskRegistry
from robot_voice_chat.control.approvals import ApprovalBroker
from robot_voice_chat.control.supervisor import MotionSupervisor
from robot_voice_chat.robot_words import plain_instruction

logger = structlog.get_logger(__name__)
# "abort", "cancel that", "please cancel the mission", "never mind", "forget it"; the softer
# phrases only as the whole request ("never mind the door, go on" is not an abort)
_ABORT = re.compile(r"\b(?:abort|cancel)\b")
_WHOLE = re.compile(
    r"^(?:ok(?:ay)?\s+|please\s+|no\s+)*(?:never ?mind|forget it|give up|quit)"
    r"(?:\s+(?:it|that|the mission|please))*$"
)
# "don't cancel", "do not abort", "never cancel it": heard as no abort
_NEGATED = re.compile(r"\b(?:don'?t|do not|never|not)\s+(?:\w+\s+)?(?:abort|cancel)\b")


def is_abort(text: str) -> bool:
    """Whether ``text`` asks to end the running mission (not a stop: stops stop)."""
    said = re.sub(r"[^\w' ]+", " ", text.lower()).strip()
    said = re.sub(r"\s+", " ", said)
    if _NEGATED.search(said):
        return False
    return bool(_ABORT.search(said) or _WHOLE.match(said))


def aborted_summary(mission: Mission) -> str:
    """How the mission's end is told (the summary card and the spoken line)."""
    return f"I aborted the mission ({plain_instruction(mission.instruction)}) as you asked."


async def abort_run(
    run: MissionRun,
    *,
    text: str,
    registry: TaskRegistry,
    dispatcher: TaskDispatcher,
    approvals: ApprovalBroker | None,
) -> str:
    """End ``run`` as cancelled and cancel its motion now; what the person is shown at once
    (the summary is told when the loop closes the mission)."""
    mission = run.mission
    run.finished = ("cancelled", aborted_summary(mission))
    if run.llm_call is not None:
        run.llm_call.cancel()
    if approvals is not None:  # nothing waiting for a yes may run for an aborted mission
        approvals.deny_all("the mission was aborted", mission.id)
    live = registry.live(mission.id)
    await asyncio.gather(*(dispatcher.end_task(handle) for handle in live))
    run.wakeup.set()  # a loop waiting for events ends now
    logger.warning(
        "mission_aborted", said=text, mission_id=mission.id, cancelled=[h.task_id for h in live]
    )
    return aborting_note(mission)


def aborting_note(mission: Mission) -> str:
    """What the person is shown at once when their abort was heard."""
    return f"Aborting the mission ({plain_instruction(mission.instruction)})."


def busy_note(mission: Mission, supervisor: MotionSupervisor | None) -> str:
    """The one sentence shown for any other turn while a mission runs (the planner hears the
    turn and may answer it itself); the stop is offered only while every motion server
    answers the brain (issue 27)."""
    doing = f"{plain_instruction(mission.instruction)}; it is {mission.state}"
    offer = supervisor is None or supervisor.all_fresh()
    how = "; say stop to halt me, or abort to end the mission" if offer else ""
    return f"I'm busy with a mission ({doing}) and passed your message on to it{how}."
