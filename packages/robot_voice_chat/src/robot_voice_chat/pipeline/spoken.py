"""Spoken turns: one utterance → the recognizer (with the live vocabulary) → what is done.

Never a wrong action from speech:

* words the recognizer rejected (outside what the robot understands, too unsure, nothing
  said) are not a turn: the robot says it did not catch that;
* a motion command heard with middling confidence is read back first ("Did you say: go to
  the kitchen? (yes or no)"); "yes" — or the same command said again — carries it out, "no"
  or anything else drops it;
* "stop" is always acted on at once (a stop is never wrong);
* with a wake phrase (``chat.wake_phrase``), what the robot's own microphone hears is a turn
  only when it starts with it ("robbie, go to the kitchen"): chatter near the robot is not a
  command. A stop needs none, nor the answer to a read-back. Push-to-talk needs none (the press
  says it is for the robot).

The vocabulary is the live one: before each utterance the places are read from
``navigation.list_locations`` (when the navigation server answers) and the things the robot
has seen from ``episodic.known_labels`` (when memory runs), and the recognizer rebuilds its
grammar when they changed, so a place added to the map, or a thing the camera saw, is
understood without a restart.
"""

from __future__ import annotations

import asyncio
import time
import uuid
from dataclasses import dataclass, replace

import structlog

from robot_voice_chat.pipeline.chat import ChatPipeline, TurnResult
from robot_voice_chat.services.emitter.base import EventEmitter
from robot_voice_chat.services.speech.audio import Utterance
from robot_voice_chat.services.speech.base import Heard, SpeechInput, SpeechOutput
from robot_voice_chat.services.speech.vocabulary import (
    KNOWN_LABELS,
    NO,
    YES,
    addressed,
    is_stop,
    labels_from_listing,
    places_from_listing,
    words_of,
)
from robot_voice_chat.services.tools.base import ToolBackend
from robot_voice_chat.socket_events import ChatMessage

logger = structlog.get_logger(__name__)

LIST_LOCATIONS = "navigation.list_locations"
MAX_LABELS = 300  # the grammar stays small enough to decode in real time
NOT_CAUGHT = "Sorry, I didn't catch that. Please say it again."
DROPPED = "OK, I won't do that."
READ_BACK_TTL_S = 60.0  # a read-back not answered within this is forgotten


@dataclass
class SpokenResult:
    heard: Heard
    turn: TurnResult | None  # None: no turn was made (rejected, or read back)
    reply: str
    read_back: bool = False
    addressed: bool = True  # False: the wake phrase was missing, nothing was answered

    @property
    def outcome(self) -> str:
        """What came of the turn: acted (a turn was made), read_back, not_addressed or
        not_acted."""
        if self.turn is not None:
            return "acted"
        if not self.addressed:
            return "not_addressed"
        return "read_back" if self.read_back else "not_acted"


@dataclass
class _Pending:
    text: str
    asked_at: float


class SpokenTurns:
    """The brain's spoken-turn service (the audio route and the microphone node use it)."""

    def __init__(
        self,
        *,
        speech_input: SpeechInput,
        pipeline: ChatPipeline,
        tools: ToolBackend,
        emitter: EventEmitter,
        speech_output: SpeechOutput,
        places_timeout_s: float = 2.0,
        wake_phrase: str = "",
    ) -> None:
        self._input = speech_input
        self._pipeline = pipeline
        self._tools = tools
        self._emitter = emitter
        self._speech = speech_output
        self._places_timeout_s = places_timeout_s
        self._wake = " ".join(words_of(wake_phrase))
        self._pending: _Pending | None = None
        self._labels: list[str] = []
        self._lock = asyncio.Lock()

    @property
    def recognizer(self) -> str:
        return self._input.name

    async def refresh_vocabulary(self) -> bool:
        """Read the live places and the things the robot has seen and hand them to the
        recognizer (True: it rebuilt)."""
        tools = {t.name for t in self._tools.list_tools()}
        if LIST_LOCATIONS not in tools:
            return False
        result = await self._tools.call_tool(LIST_LOCATIONS, {}, self._places_timeout_s)
        if result.is_error:  # the last vocabulary stays in use
            logger.warning("speech_places_unread", error=result.text[:200])
            return False
        places = places_from_listing(result.text)
        if not places:
            return False
        if KNOWN_LABELS in tools:
            await self._read_labels()
        return self._input.update_vocabulary(places, self._labels, wake=self._wake)

    async def _read_labels(self) -> None:
        """What episodic memory has seen ("umbrella"): a thing the camera saw can be named.
        An unread answer keeps the last labels."""
        result = await self._tools.call_tool(KNOWN_LABELS, {}, self._places_timeout_s)
        labels = None if result.is_error else labels_from_listing(result.text)
        if labels is None:
            logger.warning("speech_labels_unread", error=result.text[:200])
            return
        self._labels = labels[:MAX_LABELS]

    async def hear(self, utterance: Utterance, *, from_microphone: bool = False) -> SpokenResult:
        """``from_microphone``: the robot's own microphone (the wake phrase applies)."""
        async with self._lock:  # one utterance at a time: a read-back belongs to its answer
            started = time.perf_counter()
            await self.refresh_vocabulary()
            heard = await self._input.hear(utterance)
            text, named = addressed(heard.text, self._wake) if self._wake else (heard.text, False)
            if named:
                heard = replace(heard, text=text)
            if from_microphone and self._wake and not (named or self._may_skip_wake(heard)):
                logger.info("speech_not_addressed", text=heard.text)
                result = SpokenResult(heard, None, "", addressed=False)
            else:
                result = await self._act(heard)
            logger.info(
                "speech_turn_answered",
                outcome=result.outcome,
                duration_ms=round((time.perf_counter() - started) * 1000, 1),
            )
            return result

    def _may_skip_wake(self, heard: Heard) -> bool:
        """A stop, or the answer to the question the robot just asked."""
        pending = self._pending
        asked = pending is not None and time.monotonic() - pending.asked_at <= READ_BACK_TTL_S
        return heard.kind == "stop" or is_stop(heard.text) or (asked and heard.kind == "answer")

    async def _act(self, heard: Heard) -> SpokenResult:
        if heard.notice:
            await self._tell(heard.notice)
        if not heard.usable:
            logger.info("speech_not_caught", reason=heard.rejected, text=heard.text)
            await self._tell(NOT_CAUGHT)
            return SpokenResult(heard, None, NOT_CAUGHT)
        pending, self._pending = self._pending, None
        if pending is not None and time.monotonic() - pending.asked_at <= READ_BACK_TTL_S:
            said = " ".join(words_of(heard.text))
            if said in YES or said == pending.text:  # "yes", or the same command said again
                logger.info("speech_read_back_confirmed", text=pending.text)
                return SpokenResult(heard, await self._pipeline.handle_turn(pending.text), "")
            if said in NO:
                await self._tell(DROPPED)
                return SpokenResult(heard, None, DROPPED)
        if heard.kind == "stop":
            return SpokenResult(heard, await self._pipeline.handle_turn(heard.text), "")
        if heard.confirm and heard.kind == "motion":
            self._pending = _Pending(heard.text, time.monotonic())
            question = f"Did you say: {heard.text}? (yes or no)"
            await self._emitter.emit(  # what was heard, shown in the conversation
                ChatMessage(turn_id=uuid.uuid4().hex[:8], role="user", text=heard.text)
            )
            logger.info("speech_read_back", text=heard.text, confidence=heard.confidence)
            await self._tell(question)
            return SpokenResult(heard, None, question, read_back=True)
        result = await self._pipeline.handle_turn(heard.text)
        return SpokenResult(heard, result, result.reply)

    async def _tell(self, text: str) -> None:
        await self._emitter.emit(
            ChatMessage(turn_id=uuid.uuid4().hex[:8], role="assistant", text=text)
        )
        await self._speech.say(text)
