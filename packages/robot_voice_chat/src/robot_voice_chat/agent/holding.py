"""What the gripper holds, read before the robot speaks of the object (issue 39 item 3).

After a failure, a restart of a server, a stop or an abort the plan's own idea of the object is
no longer to be trusted: a killed arm server may have finished the grasp, an aborted carry
leaves the package in the gripper 20 m from anywhere. So a mission that did not succeed is told
with what the arm's server says now (``manipulation.get_held``), and where the robot is (the
nearest named place, from ``navigation.list_locations``' distances), in the words of
``robot_voice_chat.held_words``.
"""

from __future__ import annotations

import asyncio
import time
import uuid
from collections.abc import Iterable

import structlog

from robot_voice_chat.agent.mission import PlanStep
from robot_voice_chat.control.context import DispatchContext, dispatching
from robot_voice_chat.held_words import (
    Held,
    held_from,
    says_it_holds,
    still_holding,
    whereabouts_of,
    without_false_places,
)
from robot_voice_chat.services.emitter.base import EventEmitter
from robot_voice_chat.services.speech.base import SpeechOutput
from robot_voice_chat.services.tools.base import ToolBackend
from robot_voice_chat.socket_events import ChatMessage

logger = structlog.get_logger(__name__)

GET_HELD = "manipulation.get_held"
LIST_LOCATIONS = "navigation.list_locations"
READ_TIMEOUT_S = 3.0
"""At most this long for each read at a mission's end (a lost server answers an error sooner)."""
NAVIGATION_WAIT_S = 5.0
"""A restarted brain connects to every server at once: the arm's may answer before navigation,
whose places say where the robot is (a fresh-clone CI run told the held package without "near
the mailroom"). Waited for this long, when navigation is configured."""
ARM_BACK_WAIT_S = 20.0
"""After a pick, at most this long for an arm server that does not answer (a restart takes
5–15 s on a busy robot) before the robot says it cannot tell what it holds."""
ARM_POLL_S = 0.5
CANT_TELL = "My arm isn't answering, so I can't tell whether I'm still holding what I picked up."
HANDS = ("manipulation.pick", "manipulation.place", "manipulation.release")


def picked_last(steps: Iterable[PlanStep]) -> bool:
    """The last hand action that succeeded was a pick: the thing may be in the gripper."""
    done = [s.tool for s in steps if s.tool in HANDS and s.status == "succeeded"]
    return bool(done) and done[-1] == HANDS[0]


async def read_held(tools: ToolBackend, timeout_s: float = READ_TIMEOUT_S) -> Held:
    """What the gripper holds now (``Held(False)`` without an arm, or when it does not answer)."""
    if not tools.has_tool(GET_HELD):
        return Held(False)
    outcome = await tools.call_tool(GET_HELD, {}, timeout_s)
    return held_from(outcome.text, outcome.is_error)


async def whereabouts(tools: ToolBackend, timeout_s: float = READ_TIMEOUT_S) -> str | None:
    """Where the robot is in words, or None when navigation cannot say."""
    if not tools.has_tool(LIST_LOCATIONS):
        return None
    outcome = await tools.call_tool(LIST_LOCATIONS, {}, timeout_s)
    return None if outcome.is_error else whereabouts_of(outcome.text)


async def tell_what_is_held(
    tools: ToolBackend,
    summary: str,
    timeout_s: float = READ_TIMEOUT_S,
    picked: bool = False,
    arm_back_s: float = ARM_BACK_WAIT_S,
) -> str:
    """The end of a mission that did not succeed, told with what the gripper holds now: the
    held thing and where the robot is added (once), a claim that it is elsewhere dropped.
    Unchanged when the gripper is empty. ``picked``: the mission's last hand action was a
    pick, so the thing may still be held — an arm that does not answer (its server
    restarting) is waited for, at most ``arm_back_s``, and if it stays silent the robot says
    it cannot tell."""
    timeout_s = min(timeout_s, READ_TIMEOUT_S)
    started = time.monotonic()
    held = await read_held(tools, timeout_s)
    while picked and not held.known and time.monotonic() - started < arm_back_s:
        await asyncio.sleep(ARM_POLL_S)  # polled: the tool list changes when it reconnects
        held = await read_held(tools, timeout_s)
    logger.info(
        "mission_end_held_read",
        known=held.known,
        label=held.label,
        duration_ms=round((time.monotonic() - started) * 1000, 1),
    )
    if picked and not held.known:
        return f"{summary} {CANT_TELL}".strip()
    if held.label is None:
        return summary
    told = without_false_places(summary, held.label)
    if says_it_holds(told, held.label):
        return told
    where = await whereabouts(tools, timeout_s)
    return " ".join(s for s in (told, still_holding(held.label, where)) if s)


class HeldAtStart:
    """After a restart of the brain the robot says what its gripper holds (issue 39): the
    first time the arm's server connects in this process life, with no mission running, the
    gripper is read and, when it holds something, the operator is told where and asked what to
    do with it. Nothing is said about an empty gripper or an arm that does not answer."""

    def __init__(
        self,
        tools: ToolBackend,
        speech: SpeechOutput,
        emitter: EventEmitter,
        timeout_s: float = READ_TIMEOUT_S,
    ) -> None:
        self._tools = tools
        self._speech = speech
        self._emitter = emitter
        self._timeout_s = min(timeout_s, READ_TIMEOUT_S)
        self._done = False

    async def on_connect(self, server: str, idle: bool) -> str | None:
        """What was told (None when nothing was): called on every (re)connect of a server."""
        if self._done or not self._tools.has_tool(GET_HELD) or server != GET_HELD.split(".")[0]:
            return None
        self._done = True  # once per process life: a mission's end tells it from then on
        if not idle:
            return None
        started = time.monotonic()
        with dispatching(DispatchContext(may_ask=False, caller="the brain's start-up")):
            held = await read_held(self._tools, self._timeout_s)
            where = await self._where() if held.label else None
        logger.info(
            "held_at_start",
            known=held.known,
            label=held.label,
            duration_ms=round((time.monotonic() - started) * 1000, 1),
        )
        if held.label is None:
            return None
        told = still_holding(held.label, where)
        await self._emitter.emit(
            ChatMessage(turn_id=uuid.uuid4().hex[:8], role="assistant", text=told)
        )
        await self._speech.say(told)
        return told

    async def _where(self) -> str | None:
        """Where the robot is; a configured navigation server still connecting is waited for
        (``NAVIGATION_WAIT_S``)."""
        navigation = LIST_LOCATIONS.split(".")[0]
        deadline = time.monotonic() + NAVIGATION_WAIT_S
        while time.monotonic() < deadline:
            if navigation not in self._tools.servers() or self._tools.has_tool(LIST_LOCATIONS):
                break
            await asyncio.sleep(0.1)  # the connection manager says nothing we could await
        return await whereabouts(self._tools, self._timeout_s)
