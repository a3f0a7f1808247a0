"""RulesChat: the offline fast path (``llm=rules``). It reads each turn with the embedded
understanding layer over the live places (``navigation.list_locations`` first): a request it
is sure of goes to start_mission in the grammar's words, every leg in order; anything unsure
becomes one clarifying question whose answer (or "never mind") it reads next turn; questions
about the robot (where are you, which places, what can you do) are answered from its tools."""

from __future__ import annotations

import json
import re
import time
from collections.abc import AsyncIterator, Callable, Sequence
from dataclasses import dataclass, replace
from datetime import UTC, datetime
from typing import Any

from robot_language import saying
from robot_language.commands import Command
from robot_language.normalise import normalise
from robot_language.places import PlaceIndex, located
from robot_language.reading import (
    Action,
    Question,
    Reading,
    instruction_of,
)
from robot_language.recall import (
    LAST_SEEN,
    POSE_AT,
    WHAT_HAPPENED,
    Recall,
    follow_up_recall,
    read_recall,
)
from robot_language.understand import Understanding
from robot_voice_chat.held_words import held_from, held_sentence
from robot_voice_chat.services.llm.base import (
    LLMProvider,
    LLMResponse,
    Message,
    StreamEvent,
    ToolCall,
    ToolDefinition,
    ToolResult,
)
from robot_voice_chat.services.llm.rules import answers
from robot_voice_chat.services.llm.rules.plain import reason_of
from robot_voice_chat.services.llm.rules.recollection import (
    NOT_CONNECTED,
    Names,
    by_id,
    names_of,
    recollection,
)
from robot_voice_chat.services.speech.vocabulary import KNOWN_LABELS, labels_from_listing

LIST_LOCATIONS = "navigation.list_locations"
_FOLLOW_UPS = 3  # a follow-up is read against at most this many earlier turns
GET_POSE = "navigation.get_pose"
GET_HELD = "manipulation.get_held"
NO_BATTERY = (
    "I can't read my battery level: no battery reading reaches me here. "
    "Say go to the dock if I should charge."
)
RESUME = "resume_mission"  # the fast path's own tool: is there a paused mission, a latched stop
_TOLD = ("time", "doing", "distance", "smalltalk", "thanks", "resume")  # issue 32's answers
_STOP = re.compile(r"^(?:stop|halt|freeze|stopp|arrête|fermati)\b")
UNDERSTOOD = (
    "go to a place, find something (in a place), fetch something from a place and bring it "
    "somewhere (with my arm: pick it up, put it down, hand it over), watch for something, "
    "tell you what I see, where I am and which places I know, "
    "what I saw or did earlier ('when did you last see the mug?') — "
    "also several steps in a row ('go to the kitchen, then to reception')"
)
INTRO = (
    "I'm the robot's offline voice (no language model: an embedded matcher over my tools). "
    f"I can {UNDERSTOOD}. When I'm not sure what you mean, I ask. Say stop to halt me."
)


def ack(command: Command) -> str:
    """What the robot says as it starts (kept for callers that hold a single command)."""
    if command.kind == "goto":
        return f"On my way to the {command.place}."
    if command.kind == "fetch":
        return f"On my way to the {command.place} to get the {command.obj}."
    if command.kind == "find":
        return f"I'll look for the {command.obj}."
    if command.kind == "watch":
        return f"I'll watch for {command.obj}."
    if command.kind == "pick":
        return f"I'll pick up the {command.obj}."
    if command.kind in ("put", "release"):
        return "I'll put it down." if command.kind == "put" else "Here you are."
    return "Let me look."


@dataclass(frozen=True)
class _Sent:
    """Why the chat made a tool call, and what its answer needs: the question a memory call
    answers, and the live places to say places with."""

    purpose: str
    recall: Recall | None = None
    places: PlaceIndex | None = None
    about: str | None = None  # the place a distance question is about


class RulesChat(LLMProvider):
    name = "rules"

    def __init__(
        self,
        understanding: Understanding | None = None,
        clock: Callable[[], float] = time.time,
    ) -> None:
        self.understanding = understanding or Understanding()
        self._clock = clock
        self._ids = 0
        self._sent: dict[str, _Sent] = {}  # our tool call id → why we made it
        self._pending: Question | None = None
        self._last_turn: float | None = None  # when the person last spoke (this conversation)
        self._previous_turn: float | None = None  # ... before the turn being answered

    @property
    def understanding_label(self) -> str:
        return "rules + embedded matcher"

    async def chat(
        self, messages: list[Message], tools: list[ToolDefinition] | None = None
    ) -> LLMResponse:
        names = {t.name for t in tools or []}
        last = messages[-1] if messages else Message(role="user")
        if last.tool_results:
            return self._on_result(last.tool_results, messages, names)
        self._stamp_turn(messages)
        text = normalise(last.content, spoken=False)
        if _STOP.match(text) and "stop_mission" in names:
            self._pending = None
            return self._call("stop_mission", {}, "stop")
        if LIST_LOCATIONS in names:  # read the live places (and what it has seen) first
            calls = [self._tool_call(LIST_LOCATIONS, {}, _Sent("places"))]
            if KNOWN_LABELS in names:  # what it has seen: a misspelt one is read right
                calls.append(self._tool_call(KNOWN_LABELS, {}, _Sent("seen")))
            return LLMResponse(tool_calls=calls, stop_reason="tool_use")
        return self._reply(last.content, None, messages, names)

    def _on_result(
        self, results: list[ToolResult], messages: list[Message], names: set[str]
    ) -> LLMResponse:
        sents = [self._why(r, messages) for r in results]
        result, sent = results[0], sents[0]
        purpose = sent.purpose
        request = next(
            (m.content for m in reversed(messages) if m.role == "user" and m.content), ""
        )
        if purpose == "places":
            places = None if result.is_error else self.understanding.places(result.content)
            seen = [r for r, s in zip(results, sents, strict=True) if s.purpose == "seen"]
            return self._reply(request, places, messages, names, _labels(seen))
        if purpose == "pose":
            return LLMResponse(text=_where(result, names_of(sent.places)))
        if purpose == "held":
            return LLMResponse(text=held_sentence(held_from(result.content, result.is_error)))
        if purpose in ("doing", "distance", "resume"):
            return LLMResponse(text=_told(sent, result))
        if purpose == "history":
            recall = sent.recall
            tool = recall.tool if recall else _tool_of(result, messages)
            text = recollection(
                recall, tool, result.content, result.is_error, names_of(sent.places), request
            )
            if recall is not None and recall.offer and recall.obj and "start_mission" in names:
                self._pending = _look_offer(recall.obj)  # asked; only a yes starts a search
                text = f"{text} {self._pending.text}"
            return LLMResponse(text=text)
        if result.is_error:
            return LLMResponse(text=f"That didn't work: {reason_of(result.content)}.")
        if purpose == "stop":  # what the stop could confirm, never more (issue 27)
            return LLMResponse(text=result.content or "Stopped.")
        return LLMResponse(text="Done.")

    def _why(self, result: ToolResult, messages: list[Message]) -> _Sent:
        sent = self._sent.pop(result.tool_call_id, None)
        return sent or _Sent(_purpose_of(result, messages))

    def _reply(
        self,
        text: str,
        places: PlaceIndex | None,
        messages: list[Message],
        names: set[str],
        seen: Sequence[str] = (),
    ) -> LLMResponse:
        reading: Reading | None = None
        pending, self._pending = self._pending, None
        if pending is not None and _asked(pending, messages):
            reading = self.understanding.follow_up(pending, text, places)
        if reading is None:
            reading = _history_follow_up(text, messages, places)
        if reading is None:
            reading = self.understanding.understand(text, places, seen)
        if reading.kind == "act" and "start_mission" in names:
            said = saying.plan(reading.actions, places)
            missing = _missing_service(reading.actions, names)
            if missing is not None:  # refused now, not after an "OK" the mission takes back
                return LLMResponse(text=f"I can't {said} right now: my {missing} is not connected.")
            arguments = {"instruction": instruction_of(reading.actions), "ack": f"OK, I'll {said}."}
            return self._call("start_mission", arguments, "mission")
        if reading.kind == "ask" and reading.question is not None:
            self._pending = reading.question
            return LLMResponse(text=reading.question.text)
        if reading.kind == "stop" and "stop_mission" in names:
            return self._call("stop_mission", {}, "stop")
        if reading.kind == "answer" and reading.recall is not None:
            return self._recall(reading.recall, places, names)
        if reading.kind == "answer" and reading.topic in _TOLD:
            return self._tell(reading, places, names)
        if reading.kind == "answer":
            return self._answer(reading.topic, places, names)
        if reading.kind == "greet":
            return LLMResponse(text=f"Hello! {INTRO}")
        if reading.kind in ("refuse", "cancel") and reading.text:
            more = (
                ""
                if reading.kind == "cancel" or "I know:" in reading.text
                else f" I can {UNDERSTOOD}."
            )
            offline = (
                "I can't do that offline: " if reading.intent in ("unclear", "out_of_scope") else ""
            )
            return LLMResponse(text=offline + reading.text + more)
        return LLMResponse(
            text=f"I can't do that offline: I didn't understand {text.strip()!r}. {INTRO}"
        )

    def _answer(self, topic: str, places: PlaceIndex | None, names: set[str]) -> LLMResponse:
        if topic == "where":
            if GET_POSE in names:
                return self._call(GET_POSE, {}, "pose", places=places)
            return LLMResponse(
                text="I can't tell where I am: the navigation server is not connected."
            )
        if topic == "places":
            if places is None or not places.places:
                return LLMResponse(
                    text="I don't know any places: the navigation server is not connected."
                )
            listed = ", ".join(p.spoken() for p in places.places)
            return LLMResponse(text=f"I know {len(places.places)} places: {listed}.")
        if topic == "holding":
            if GET_HELD in names:
                return self._call(GET_HELD, {}, "held")
            return LLMResponse(text="I can't tell what I'm holding: my arm is not connected.")
        if topic == "battery":
            return LLMResponse(text=NO_BATTERY)
        return LLMResponse(text=INTRO)

    def _tell(self, reading: Reading, places: PlaceIndex | None, names: set[str]) -> LLMResponse:
        """The time, what I'm doing, how far a place is, small talk, thanks, continue: answered
        from the clock, the pose and the place list, never by moving."""
        topic = reading.topic
        if topic == "time":
            return LLMResponse(text=answers.clock_sentence(self._clock()))
        if topic == "resume":
            if RESUME in names:  # the brain knows whether a stop is latched
                return self._call(RESUME, {}, "resume")
            return LLMResponse(text=answers.NOTHING_TO_CONTINUE)
        if topic == "doing":
            if GET_POSE in names:
                return self._call(GET_POSE, {}, "doing", places=places)
            return LLMResponse(text=answers.doing_sentence(None, False, places))
        if topic == "distance" and reading.about is not None and places is not None:
            place = places.get(reading.about)
            if place is not None and GET_POSE in names:
                return self._call(GET_POSE, {}, "distance", places=places, about=place.name)
            if place is not None:
                return LLMResponse(text=answers.distance_sentence(place, None, False, places))
        if topic == "distance" and not reading.text:
            return LLMResponse(
                text="I can't tell how far that is: the navigation server is not connected."
            )
        return LLMResponse(text=reading.text or "You're welcome.")

    def _recall(self, recall: Recall, places: PlaceIndex | None, names: set[str]) -> LLMResponse:
        """A question about the past: one episodic call (never a motion)."""
        if recall.tool not in names:
            return LLMResponse(text=NOT_CONNECTED)
        arguments = dict(recall.arguments)
        if recall.place is not None and places is not None and places.places:
            match = places.resolve(recall.place)
            if not match.sure:
                return LLMResponse(text=_unsure_place(recall.place, match.names, places))
            arguments["place"] = match.names[0]
            recall = replace(recall, arguments=arguments, place=match.names[0])
        if recall.since_turn and self._previous_turn is not None:
            arguments["start"] = _iso(self._previous_turn)
            recall = replace(recall, arguments=arguments, said="since your last turn")
        return self._call(recall.tool, arguments, "history", recall=recall, places=places)

    def _stamp_turn(self, messages: list[Message]) -> None:
        """A new turn (not a tool round): remember when the person spoke before it, if this
        conversation holds an earlier turn (the pipeline keeps a history)."""
        earlier = sum(1 for m in messages if m.role == "user" and m.content) > 1
        now = self._clock()
        self._previous_turn = self._last_turn if earlier else None
        self._last_turn = now

    def _call(
        self,
        name: str,
        arguments: dict[str, Any],
        purpose: str,
        recall: Recall | None = None,
        places: PlaceIndex | None = None,
        about: str | None = None,
    ) -> LLMResponse:
        call = self._tool_call(name, arguments, _Sent(purpose, recall, places, about))
        return LLMResponse(tool_calls=[call], stop_reason="tool_use")

    def _tool_call(self, name: str, arguments: dict[str, Any], sent: _Sent) -> ToolCall:
        self._ids += 1
        call = ToolCall(id=f"rules_chat_{self._ids}", name=name, arguments=arguments)
        self._sent[call.id] = sent
        while len(self._sent) > 64:  # answers that never came back
            self._sent.pop(next(iter(self._sent)))
        return call

    async def chat_stream(
        self, messages: list[Message], tools: list[ToolDefinition] | None = None
    ) -> AsyncIterator[StreamEvent]:
        response = await self.chat(messages, tools)
        words = re.findall(r"\S+\s*", response.text)
        for word in words:
            yield StreamEvent(delta=word)
        yield StreamEvent(response=response)


# the services a request needs, by the tool-name prefix of the servers the missions call
_DRIVES, _LOOKS = ("navigation.", "navigation"), ("skill_control.", "camera")


def _missing_service(actions: list[Action], names: set[str]) -> str | None:
    """The service a request needs that lists no tools now (its server is down), if any."""
    needed = []
    for action in actions:
        if action.place is not None or action.to is not None or action.kind == "goto":
            needed.append(_DRIVES)
        if action.kind in ("find", "fetch", "watch"):
            needed.append(_LOOKS)
    for prefix, service in needed:
        if not any(name.startswith(prefix) for name in names):
            return service
    return None


def _asked(question: Question, messages: list[Message]) -> bool:
    """Our question is the conversation's last reply (or the pipeline keeps no history)."""
    replies = [m.content for m in messages if m.role == "assistant" and m.content]
    return not replies or replies[-1].strip().endswith(question.text)


def _told(sent: _Sent, result: ToolResult) -> str:
    """The answer to a doing / distance / continue question from its tool's result."""
    if sent.purpose == "resume":
        return result.content if not result.is_error else answers.NOTHING_TO_CONTINUE
    if sent.purpose == "doing":
        return answers.doing_sentence(result.content, result.is_error, sent.places)
    place = sent.places.get(sent.about) if sent.places is not None and sent.about else None
    if place is None:
        return "I can't tell how far that is right now."
    return answers.distance_sentence(place, result.content, result.is_error, sent.places)


def _where(result: ToolResult, names: Names = by_id) -> str:
    if result.is_error:
        return f"I can't tell where I am right now: {reason_of(result.content)}."
    try:
        pose = json.loads(result.content)
    except ValueError:
        pose = None
    if not isinstance(pose, dict):
        return "I can't tell where I am right now: the navigation server gave no pose."
    if pose.get("stale"):  # the base sends no live pose: say so, not where it last was
        note = str(pose.get("pose_note") or "the robot base sends no live pose")
        return f"I can't tell where I am right now: {note}."
    if pose.get("moving") and pose.get("destination"):
        return f"I'm driving to {names(str(pose['destination']))}."
    if pose.get("at_location"):
        return f"I'm {located(names(str(pose['at_location'])))}."
    x, y = pose.get("x"), pose.get("y")
    if isinstance(x, int | float) and isinstance(y, int | float):
        return f"I'm between places, at x={x:.1f} m, y={y:.1f} m on the map."
    return "I can't tell where I am right now."


_PURPOSE_OF_TOOL = {
    LIST_LOCATIONS: "places",
    KNOWN_LABELS: "seen",
    GET_POSE: "pose",
    GET_HELD: "held",
    RESUME: "resume",
    "start_mission": "mission",
    "stop_mission": "stop",
    WHAT_HAPPENED: "history",
    LAST_SEEN: "history",
    POSE_AT: "history",
}


def _history_follow_up(
    text: str, messages: list[Message], places: PlaceIndex | None = None
) -> Reading | None:
    """A short follow-up ("and the laptop?", "what about 2:24 pm?", "what about the
    reception?") to the person's earlier questions about the past in this conversation, read
    against them (a few turns back); ``places``: the live place list, so a follow-up naming a
    place is read as that place."""
    said = [m.content for m in messages if m.role == "user" and m.content][:-1][-_FOLLOW_UPS:]
    is_place = places.only_place if places is not None and places.places else None
    recall: Recall | None = None
    for earlier in said:
        recall = (follow_up_recall(earlier, recall, is_place) if recall else None) or read_recall(
            earlier
        )
    if recall is None:
        return None
    read = follow_up_recall(text, recall, is_place)
    return Reading("answer", topic="history", recall=read, intent="history") if read else None


def _look_offer(obj: str) -> Question:
    """ "where is the mug?" is answered from memory; going to look is offered, never done."""
    thing = obj if obj.split(" ", 1)[0] in ("the", "a", "an", "my") else f"the {obj}"
    return Question(
        text=f"Shall I go and look for {thing}?",
        mode="confirm",
        actions=[Action("find", obj=obj)],
    )


def _unsure_place(phrase: str, names: list[str], places: PlaceIndex) -> str:
    if names:
        return f"Which place do you mean: {', '.join(places.spoken(n) for n in names)}?"
    known = ", ".join(p.spoken() for p in places.places)
    return f"I don't know a place called '{phrase}'. I know: {known}."


def _iso(stamp: float) -> str:
    """The person's previous turn as an ISO time the episodic server reads (no arithmetic)."""
    return datetime.fromtimestamp(stamp, UTC).isoformat(timespec="milliseconds")


def _tool_of(result: ToolResult, messages: list[Message]) -> str:
    return next(
        (
            call.name
            for m in messages
            if m.role == "assistant"
            for call in m.tool_calls
            if call.id == result.tool_call_id
        ),
        "",
    )


def _labels(results: list[ToolResult]) -> list[str]:
    """What ``episodic.known_labels`` answered, as spoken; none when it failed."""
    for result in results:
        labels = None if result.is_error else labels_from_listing(result.content)
        if labels:
            return labels
    return []


def _purpose_of(result: ToolResult, messages: list[Message]) -> str:
    """Why we made a call whose id we did not give (an API between us and the brain, e.g. an
    OpenAI-compatible server, names the calls itself): the called tool tells."""
    return _PURPOSE_OF_TOOL.get(_tool_of(result, messages), "")
