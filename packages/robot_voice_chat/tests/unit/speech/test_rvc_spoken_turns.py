"""Spoken turns (issue 36): a rejected utterance is no turn ("I didn't catch that"); a motion
heard with middling confidence is read back, and only "yes" carries it out; a stop is acted on
at once; the recognizer gets the live places before each utterance."""

from __future__ import annotations

import json
from collections.abc import Iterable
from dataclasses import dataclass, field

import numpy as np

from robot_voice_chat.pipeline.chat import TurnResult
from robot_voice_chat.pipeline.spoken import DROPPED, NOT_CAUGHT, SpokenTurns
from robot_voice_chat.services.emitter.base import FakeEventEmitter
from robot_voice_chat.services.speech.audio import Utterance
from robot_voice_chat.services.speech.base import Heard, SpeechInput
from robot_voice_chat.services.speech.fake import FakeSpeechOutput
from robot_voice_chat.services.tools.fake import FakeToolBackend
from robot_voice_chat.socket_events import ChatMessage

LOCATIONS = {"locations": [{"name": "kitchen", "aliases": []}, {"name": "mailroom"}]}


class ScriptedInput(SpeechInput):
    name = "scripted recognizer"

    def __init__(self, heard: list[Heard]) -> None:
        self.heard = heard
        self.places: list[list[list[str]]] = []
        self.objects: list[list[str]] = []

    async def transcribe(self, audio: bytes, mime_type: str) -> str:
        raise AssertionError("hear() is used")

    async def hear(self, utterance: Utterance) -> Heard:
        return self.heard.pop(0)

    def update_vocabulary(
        self, places: Iterable[Iterable[str]], objects: Iterable[str] = (), wake: str = ""
    ) -> bool:
        self.places.append([list(p) for p in places])
        self.objects.append(list(objects))
        self.wake = wake
        return True


@dataclass
class RecordingPipeline:
    turns: list[str] = field(default_factory=list)

    async def handle_turn(self, text: str, turn_id: str | None = None) -> TurnResult:
        self.turns.append(text)
        return TurnResult("t1", f"done: {text}", "fast")


def spoken(
    heard: list[Heard], wake_phrase: str = ""
) -> tuple[SpokenTurns, RecordingPipeline, FakeEventEmitter]:
    tools = FakeToolBackend()
    tools.add("navigation.list_locations", lambda a: LOCATIONS)
    pipeline, emitter = RecordingPipeline(), FakeEventEmitter()
    turns = SpokenTurns(
        speech_input=ScriptedInput(heard),
        pipeline=pipeline,  # type: ignore[arg-type]
        tools=tools,
        emitter=emitter,
        speech_output=FakeSpeechOutput(),
        wake_phrase=wake_phrase,
    )
    return turns, pipeline, emitter


UTTERANCE = Utterance.from_pcm(np.zeros(1600, np.int16))


def said(emitter: FakeEventEmitter) -> list[str]:
    return [e.text for e in emitter.of(ChatMessage) if isinstance(e, ChatMessage)]


async def test_a_rejected_utterance_is_no_turn() -> None:
    turns, pipeline, emitter = spoken(
        [Heard("get my mug from corridor b", 0.1, "x", "motion", rejected="low_confidence")]
    )
    result = await turns.hear(UTTERANCE)
    assert result.turn is None
    assert result.reply == NOT_CAUGHT
    assert result.outcome == "not_acted"
    assert pipeline.turns == []
    assert said(emitter) == [NOT_CAUGHT]


async def test_a_middling_motion_is_read_back_and_yes_carries_it_out() -> None:
    turns, pipeline, emitter = spoken(
        [Heard("go to the kitchen", 0.4, "x", "motion", confirm=True), Heard("yes", 0.7, "x")]
    )
    asked = await turns.hear(UTTERANCE)
    assert asked.read_back
    assert asked.outcome == "read_back"
    assert asked.reply == "Did you say: go to the kitchen? (yes or no)"
    assert pipeline.turns == []  # nothing moved before the answer
    confirmed = await turns.hear(UTTERANCE)
    assert pipeline.turns == ["go to the kitchen"]
    assert confirmed.turn is not None
    assert confirmed.outcome == "acted"
    assert said(emitter) == ["go to the kitchen", "Did you say: go to the kitchen? (yes or no)"]


async def test_no_drops_a_read_back_and_a_later_yes_does_nothing() -> None:
    turns, pipeline, _ = spoken(
        [
            Heard("go to the kitchen", 0.4, "x", "motion", confirm=True),
            Heard("no", 0.8, "x", "answer"),
            Heard("yes", 0.8, "x", "answer"),
        ]
    )
    await turns.hear(UTTERANCE)
    assert (await turns.hear(UTTERANCE)).reply == DROPPED
    await turns.hear(UTTERANCE)
    assert pipeline.turns == ["yes"]  # an answer to nothing is an ordinary turn


async def test_a_stop_is_acted_on_at_once_and_a_confident_command_is_a_turn() -> None:
    turns, pipeline, _ = spoken(
        [Heard("stop", 0.1, "x", "stop", confirm=True), Heard("go to the kitchen", 0.9, "x")]
    )
    await turns.hear(UTTERANCE)
    await turns.hear(UTTERANCE)
    assert pipeline.turns == ["stop", "go to the kitchen"]


async def test_the_recognizer_gets_the_live_places_before_each_utterance() -> None:
    turns, _, _ = spoken([Heard("yes", 0.9, "x", "answer")])
    await turns.hear(UTTERANCE)
    recognizer = turns._input
    assert isinstance(recognizer, ScriptedInput)
    assert recognizer.places == [[["kitchen"], ["mailroom"]]]
    assert json.dumps(LOCATIONS)  # the listing the fake navigation server answered


async def test_the_recognizer_listens_for_what_memory_has_seen_and_keeps_it_on_an_error() -> None:
    turns, _, _ = spoken([Heard("yes", 0.9, "x", "answer")] * 3)
    answers: list[object] = [
        {"labels": ["umbrella", "coffee_mug", "umbrella", 7], "count": 3},
        ValueError("episodic: database is locked"),
        "not json",
    ]

    def known_labels(_: dict[str, object]) -> object:
        answer = answers.pop(0)
        if isinstance(answer, Exception):
            raise answer
        return answer

    turns._tools.add("episodic.known_labels", known_labels)  # type: ignore[attr-defined]
    for _ in range(3):
        await turns.hear(UTTERANCE)
    recognizer = turns._input
    assert isinstance(recognizer, ScriptedInput)
    # an unreadable answer (an error, not JSON) keeps the labels last read
    assert recognizer.objects == [["umbrella", "coffee mug"]] * 3


async def test_the_same_command_said_again_confirms_a_read_back() -> None:
    motion = Heard("go to the kitchen", 0.4, "x", "motion", confirm=True)
    turns, pipeline, _ = spoken([motion, motion])
    assert (await turns.hear(UTTERANCE)).read_back
    assert not (await turns.hear(UTTERANCE)).read_back
    assert pipeline.turns == ["go to the kitchen"]


async def test_the_robots_microphone_takes_a_turn_only_after_the_wake_phrase() -> None:
    turns, pipeline, emitter = spoken(
        [
            Heard("go to the kitchen", 0.9, "x", "motion"),  # chatter nearby
            Heard("robbie go to the kitchen", 0.9, "x", "motion"),
            Heard("hey robbie what do you see", 0.9, "x", "other"),
        ],
        wake_phrase="Robbie",
    )

    chatter = await turns.hear(UTTERANCE, from_microphone=True)
    named = await turns.hear(UTTERANCE, from_microphone=True)
    called = await turns.hear(UTTERANCE, from_microphone=True)

    assert chatter.outcome == "not_addressed"
    assert chatter.reply == ""
    assert named.outcome == "acted"
    assert called.outcome == "acted"
    assert pipeline.turns == ["go to the kitchen", "what do you see"]
    assert said(emitter) == []  # nothing answered to chatter
    assert turns._input.wake == "robbie"  # type: ignore[attr-defined]  # the grammar hears it


async def test_stop_and_a_read_back_answer_need_no_wake_phrase() -> None:
    turns, pipeline, _ = spoken(
        [
            Heard("stop", 0.9, "x", "stop"),
            Heard("halt right there", None, "cloud", "other"),  # a free-form engine
            Heard("robbie go to the kitchen", 0.5, "x", "motion", confirm=True),
            Heard("yes", 0.9, "x", "answer"),
            Heard("yes", 0.9, "x", "answer"),  # nothing was asked any more
        ],
        wake_phrase="robbie",
    )

    results = [await turns.hear(UTTERANCE, from_microphone=True) for _ in range(5)]

    assert [r.outcome for r in results] == [
        "acted",
        "acted",
        "read_back",
        "acted",
        "not_addressed",
    ]
    assert pipeline.turns == ["stop", "halt right there", "go to the kitchen"]


async def test_push_to_talk_needs_no_wake_phrase() -> None:
    turns, pipeline, _ = spoken([Heard("go to the kitchen", 0.9, "x", "motion")], "robbie")

    result = await turns.hear(UTTERANCE)

    assert result.outcome == "acted"
    assert pipeline.turns == ["go to the kitchen"]
