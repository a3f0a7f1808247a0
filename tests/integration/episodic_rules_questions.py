"""The scripted office day (``robot_mcp_episodic.episode``) asked in plain words through the
brain's keyless chat: the real chat pipeline with the rules chat and its understanding layer,
over the real episodic server (its FastMCP server on an in-memory MCP connection) and the
office's places. Shared by ``test_episodic_rules_questions.py`` and
``benchmarks/episodic_accuracy.py --through rules``.

The day's clock is a :class:`ManualClock` shared by the server and the chat: a question is
asked at a moment of the day (the clock is set there; the tools answer about the time before
it), so "what did you see 30 seconds ago" has a known answer. Deterministic: no sleeps, no
randomness. The wording differs from the tool set's (``episode.questions``).
"""

from __future__ import annotations

import json
import tempfile
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mcp import Client

from robot_language.scoring import OFFICE_LIST_LOCATIONS
from robot_language.understand import Understanding
from robot_mcp_episodic.composition import EpisodicApp, build_app
from robot_mcp_episodic.config import EpisodicConfig
from robot_mcp_episodic.episode import DAY_S, Episode, ManualClock, play_office_day
from robot_mcp_episodic.timeparse import ago
from robot_stack_testing.brain.harness import make_harness
from robot_voice_chat.pipeline.chat import ChatPipeline
from robot_voice_chat.services.llm.base import ToolDefinition
from robot_voice_chat.services.llm.fake import FakeLLM
from robot_voice_chat.services.llm.rules.chat import RulesChat
from robot_voice_chat.services.tools.base import (
    ConnectionState,
    ServerListener,
    ToolBackend,
    ToolOutcome,
)
from robot_voice_chat.settings import ChatConfig, McpServerConfig

START = 1_790_000_000.0  # 2026-09-21 14:13:20 UTC: offset 640 s is 14:24, 2800 s is 15:00
LIST_LOCATIONS = "navigation.list_locations"
Shown = dict[str, tuple[float, float]]
ALICE = ("desk alice", "Alice's desk")  # the map id, or the place list's human name


class EpisodicOverMcp(ToolBackend):
    """The brain's tool port over the episodic server's own MCP session (in memory), plus the
    navigation server's place list (read-only; nothing here can move a robot)."""

    def __init__(self, client: Client, tools: list[ToolDefinition]) -> None:
        self._client = client
        self._tools = [*tools, ToolDefinition(name=LIST_LOCATIONS, description="places")]
        self.calls: list[tuple[str, dict[str, object]]] = []

    @classmethod
    async def connect(cls, client: Client) -> EpisodicOverMcp:
        listed = await client.list_tools()
        tools = [
            ToolDefinition(
                name=f"episodic.{t.name}",
                description=t.description or "",
                parameters=dict(t.input_schema),
            )
            for t in listed.tools
        ]
        return cls(client, tools)

    def list_tools(self) -> list[ToolDefinition]:
        return list(self._tools)

    async def call_tool(
        self, name: str, arguments: dict[str, object], timeout_s: float | None = None
    ) -> ToolOutcome:
        self.calls.append((name, dict(arguments)))
        if name == LIST_LOCATIONS:
            return ToolOutcome(text=OFFICE_LIST_LOCATIONS)
        server, _, tool = name.partition(".")
        if server != "episodic":
            return ToolOutcome(text=f"error: unknown tool {name!r}", is_error=True)
        result = await self._client.call_tool(tool, dict(arguments))
        text = "\n".join(getattr(block, "text", "") for block in result.content)
        return ToolOutcome(text=text, is_error=bool(result.is_error))

    def servers(self) -> dict[str, McpServerConfig]:
        return {
            "episodic": McpServerConfig(name="episodic", url="http://127.0.0.1:9203/sse"),
            "navigation": McpServerConfig(
                name="navigation", url="http://127.0.0.1:9101/sse", motion=True
            ),
        }

    def server_states(self) -> dict[str, ConnectionState]:
        return {"episodic": "connected", "navigation": "connected"}

    def add_connect_listener(self, listener: ServerListener) -> None:
        """The in-memory session never reconnects."""

    def add_disconnect_listener(self, listener: ServerListener) -> None:
        """The in-memory session is never lost."""


@dataclass(frozen=True)
class Ask:
    """A question asked ``at`` seconds into the day; the answer must hold every entry of
    ``expect`` (a tuple entry: any one of its spellings) and none of ``absent``. ``before``:
    the person said something at that offset first, in the same conversation; ``prior``:
    questions asked just before it in the same conversation (a follow-up)."""

    at: float
    text: str
    expect: tuple[str | tuple[str, ...], ...]
    absent: tuple[str, ...] = ()
    before: float | None = None
    kind: str = ""
    prior: tuple[str, ...] = ()

    def wrong(self, answer: str) -> list[str]:
        said = answer.lower()
        missing = [
            " | ".join(e) if isinstance(e, tuple) else e
            for e in self.expect
            if not any(s.lower() in said for s in (e if isinstance(e, tuple) else (e,)))
        ]
        return missing + [f"not {a!r}" for a in self.absent if a.lower() in said]


@dataclass
class Asked:
    ask: Ask
    answer: str
    route: str
    motion: list[str] = field(default_factory=list)

    @property
    def right(self) -> bool:
        return not self.ask.wrong(self.answer) and self.route == "fast" and not self.motion


@dataclass
class Day:
    app: EpisodicApp
    clock: ManualClock
    shown: Shown


def play_day(data_dir: Path) -> Day:
    clock = ManualClock(START)
    app = build_app(
        EpisodicConfig(
            data_dir=data_dir,
            record_raw=False,
            timezone="UTC",  # the day's clock-time questions ("at 3 pm") are UTC times
        ),
        record_ros=False, clock=clock,
    )  # fmt: skip
    shown = play_office_day(Episode(app.memory.indexer, app.memory.places, clock))
    app.memory.indexer.flush()
    return Day(app, clock, shown)


def _ago_options(stamp: float, now: float) -> tuple[str, ...]:
    """The server's "N s ago" for ``stamp``, give or take a frame (as the tool set allows)."""
    return tuple(dict.fromkeys(ago(stamp + d, now) for d in (-1, -0.5, 0, 0.5, 1)))


def questions(shown: Shown) -> list[Ask]:
    """The question set with its known answers (``shown``: when play_office_day showed what)."""
    end = DAY_S
    q: list[Ask] = []

    def at_end(offset: float) -> tuple[str, ...]:
        return _ago_options(START + offset, START + end)

    # last seen: where and when, in many words (asked at the end of the day)
    sightings: list[tuple[str, str | tuple[str, ...], str]] = [
        ("charger", "dock", "charger"),
        ("red mug", "meeting room", "red mug"),
        ("coffee machine", "kitchen", "coffee machine"),
        ("scissors", "reception", "scissors"),
        ("person", "reception", "person"),
        ("laptop", ALICE, "laptop"),
        ("parcel", "mailroom", "parcel"),
        ("notebook", "meeting room", "red mug"),
    ]
    phrasings = [
        "When did you last see the {x}?",
        "where did you see the {x}",
        "Have you seen the {x}?",
        "when was the last time you saw the {x}",
        "do you remember where you spotted the {x}?",
        "how long ago did you see the {x}",
    ]
    for i, (label, place, key) in enumerate(sightings):
        for j in range(3):
            text = phrasings[(i + j) % len(phrasings)].format(x=label)
            expect = (label, place, at_end(shown[key][1]))
            q.append(Ask(end, text, expect, kind="last_seen"))
    q.append(
        Ask(
            end,
            "when did you last see the mug, and where was that?",
            ("red mug", "meeting room", at_end(shown["red mug"][1])),
            kind="last_seen",
        )
    )
    q.append(Ask(end, "did you see the red mug in the kitchen?",
                 ("red mug", "kitchen", "gone", at_end(shown["red mug@kitchen"][1])),
                 kind="last_seen"))  # fmt: skip
    q.append(
        Ask(
            end,
            "Have you seen any parcels?",
            ("parcel", "mailroom", at_end(shown["parcel"][1])),
            kind="last_seen",
        )
    )
    # nothing seen: says so, never a guess
    for text in ("have you seen my umbrella?", "when did you last see a giraffe",
                 "where did you see the bicycle", "did you spot a cat anywhere?",
                 "where did I leave my keys?", "any sign of the stapler?"):  # fmt: skip
        q.append(Ask(end, text, ("I have no record of seeing",), kind="nothing"))
    q.append(
        Ask(
            end,
            "what did you see in the last 10 minutes?",
            ("I have no record of seeing anything",),
            kind="nothing",
        )
    )
    q.append(
        Ask(
            end,
            "What did you see a minute ago?",
            ("I have no record of seeing anything",),
            kind="nothing",
        )
    )
    # before the laptop was ever in view (asked at 790 s): not seen yet
    q.append(Ask(790, "have you seen the laptop?", ("I have no record of seeing",),
                 kind="nothing"))  # fmt: skip
    # what was seen N ago (asked at the reception, 790 s into the day)
    q.append(Ask(790, "what did you see 30 seconds ago?", ("scissors", "person", "reception"),
                 ("red mug",), kind="seen"))  # fmt: skip
    q.append(Ask(790, "what did you see a minute ago", ("scissors", "reception"),
                 ("red mug",), kind="seen"))  # fmt: skip
    q.append(
        Ask(
            790,
            "tell me what you saw two minutes ago",
            ("red mug", "kitchen", "scissors"),
            kind="seen",
        )
    )
    q.append(Ask(790, "when did you last see the red mug?",
                 ("red mug", "kitchen", _ago_options(START + shown["red mug@kitchen"][1],
                                                    START + 790)), kind="last_seen"))  # fmt: skip
    q.append(Ask(5000, "what have you seen in the last 10 minutes",
                 ("coffee machine", "red mug", "notebook", "parcel", "kitchen", "meeting room",
                  "mailroom"), ("scissors", "laptop"), kind="seen"))  # fmt: skip
    q.append(
        Ask(
            5000,
            "What objects did you spot in the meeting room today?",
            ("red mug", "notebook", "meeting room"),
            ("parcel", "laptop"),
            kind="seen",
        )
    )
    q.append(
        Ask(
            end,
            "what did you see in the kitchen today",
            ("red mug", "coffee machine", "kitchen"),
            ("parcel", "scissors"),
            kind="seen",
        )
    )
    # digests: what happened
    q.append(Ask(end, "what happened in the last 30 minutes?", ("dock",),
                 ("saw", "mission"), kind="digest"))  # fmt: skip
    q.append(Ask(end, "what happened in the last 2 hours?",
                 ("Evening patrol", "kitchen", "meeting room", "mailroom", "parcel", "Battery"),
                 ("Fetch the red mug",), kind="digest"))  # fmt: skip
    q.append(Ask(end, "what's been going on today?",
                 ("Fetch the red mug", "Evening patrol", "reception", ALICE),
                 kind="digest"))  # fmt: skip
    q.append(
        Ask(
            790,
            "what happened in the last five minutes",
            ("kitchen", "reception", "red mug", "scissors"),
            ("laptop",),
            kind="digest",
        )
    )
    q.append(Ask(end, "give me a recap of the last hour", ("Battery", "dock"),
                 ("parcel",), kind="digest"))  # fmt: skip
    q.append(
        Ask(
            end,
            "where have you been in the last 2 hours",
            ("kitchen", "meeting room", "mailroom", "dock"),
            kind="digest",
        )
    )
    # while I was away: since the person's previous turn, else the last hour (and says so)
    q.append(Ask(5000, "what happened while I was away?",
                 ("since you last spoke", "Evening patrol", "mailroom", "parcel"),
                 ("Fetch the red mug", "scissors"), before=850, kind="away"))  # fmt: skip
    q.append(Ask(end, "what did I miss?",
                 ("since you last spoke", "Evening patrol", "Battery", "parcel"),
                 ("scissors",), before=900, kind="away"))  # fmt: skip
    q.append(Ask(end, "catch me up", ("don't know when you left", "Battery", "dock"),
                 ("parcel",), kind="away"))  # fmt: skip
    q.append(Ask(790, "anything new since I left?", ("since you last spoke", "scissors"),
                 ("red mug", "laptop"), before=715, kind="away"))  # fmt: skip
    # where were you then (clock times are passed through as said; the server reads them)
    for text, place in (
        ("where were you at 2:24 pm?", "kitchen"),
        ("Where were you at 14:26", "reception"),
        ("where was the robot at 2:27 pm", ALICE),
        ("where were you at 3 pm", "dock"),
        ("which room were you in at 3:31 pm?", "meeting room"),
        ("where were you at 4 pm", "dock"),
        ("Where were you 2 hours ago?", "dock"),
        ("where were you at 5 pm", "dock"),
    ):
        q.append(Ask(end, text, (place,), kind="pose_at"))
    q.append(Ask(end, "what were you doing at 2:24 pm", ("kitchen", "Fetch the red mug"),
                 kind="pose_at"))  # fmt: skip
    q.append(Ask(end, "what were you doing at 3:31 pm", ("meeting room", "Evening patrol"),
                 kind="pose_at"))  # fmt: skip
    # what was seen at a clock time: the server's window of 5 minutes either side, said back
    q.append(Ask(end, "what did you see at 2:24 pm?",
                 ("red mug", "coffee machine", "kitchen", "scissors",
                  "between 14:19 and 14:29 UTC"), ("parcel", "notebook"), kind="seen"))  # fmt: skip
    q.append(Ask(end, "What did you see around 15:30", ("red mug", "notebook", "meeting room",
                 "between 15:25 and 15:35 UTC"), ("scissors", "laptop"), kind="seen"))  # fmt: skip
    q.append(Ask(end, "what did you see at half past two",
                 ("scissors", "laptop", "between 14:25 and 14:35 UTC"), ("red mug", "parcel"),
                 kind="seen"))  # fmt: skip
    q.append(Ask(end, "what did you spot in the mailroom around 3:32 pm", ("parcel", "mailroom"),
                 ("red mug", "notebook"), kind="seen"))  # fmt: skip
    q.append(Ask(end, "what did you see at 3 pm?",
                 ("I have no record of seeing anything around 3 pm",), kind="nothing"))  # fmt: skip
    q.append(Ask(790, "where were you a minute ago?", ("reception",), kind="pose_at"))
    q.append(Ask(790, "where were you 3 minutes ago", ("kitchen",), kind="pose_at"))
    return q


def held_out(shown: Shown) -> list[Ask]:
    """A held-out set: written apart from the grammar (after :func:`questions` was tuned on),
    the way operators type or say things, over the same day. Never used to tune the grammar;
    its accuracy is reported separately."""
    end = DAY_S

    def ago_at(key: str, now: float = end, which: int = 1) -> tuple[str, ...]:
        return _ago_options(START + shown[key][which], START + now)

    nothing = ("no record",)
    return [
        # last seen, casually worded (asked at the end of the day)
        Ask(end, "u seen my keys?", nothing, kind="nothing"),
        Ask(end, "when was the last time the red mug showed up",
            ("red mug", "meeting room", ago_at("red mug")), kind="last_seen"),
        Ask(end, "where's the last place you saw the scissors",
            ("scissors", "reception", ago_at("scissors")), kind="last_seen"),
        Ask(end, "seen the laptop anywhere?", ("laptop", ALICE, ago_at("laptop")),
            kind="last_seen"),
        Ask(end, "any idea where the charger is?", ("charger", "dock", ago_at("charger")),
            kind="last_seen"),
        Ask(end, "did you notice a package in the mailroom earlier",
            ("parcel", "mailroom", ago_at("parcel")), kind="last_seen"),
        Ask(end, "Where did you spot the coffee machine last?",
            ("coffee machine", "kitchen", ago_at("coffee machine")), kind="last_seen"),
        Ask(end, "have you seen anyone today?", ("person", "reception", ago_at("person")),
            kind="last_seen"),
        Ask(end, "last time you saw the notebook?",
            ("notebook", "meeting room", ago_at("red mug")), kind="last_seen"),
        Ask(end, "is my mug still in the kitchen?", ("mug", "kitchen", "gone"),
            kind="last_seen"),
        Ask(end, "how many minutes ago did you see the parcel",
            ("parcel", "mailroom", ago_at("parcel")), kind="last_seen"),
        Ask(end, "did you come across any scissors?", ("scissors", "reception"),
            kind="last_seen"),
        Ask(end, "where did you see Alice's laptop?", ("laptop", ALICE), kind="last_seen"),
        Ask(end, "when did you first see the parcel today?",
            ("parcel", "mailroom", ago_at("parcel#1", which=0)), kind="last_seen"),
        Ask(end, "how long did you see the scissors for?",
            ("scissors", ("39 s", "40 s", "41 s")), kind="last_seen"),
        # follow-ups in the same conversation
        Ask(end, "and the laptop?", ("laptop", ALICE), prior=("have you seen the scissors?",),
            kind="follow_up"),
        Ask(end, "where was that?", ("meeting room",),
            prior=("when did you last see the red mug?",), kind="follow_up"),
        Ask(end, "and in the mailroom?", ("parcel", "mailroom"), ("coffee machine",),
            prior=("what did you see in the kitchen?",), kind="follow_up"),
        Ask(end, "what about 2:24 pm?", ("kitchen",), prior=("where were you at 3 pm",),
            kind="follow_up"),
        # nothing seen: says so
        Ask(end, "have you seen a dog today?", nothing, kind="nothing"),
        Ask(end, "any sign of my wallet?", nothing, kind="nothing"),
        Ask(end, "did you spot my glasses anywhere", nothing, kind="nothing"),
        Ask(end, "when did you last see the printer", nothing, kind="nothing"),
        Ask(700, "have you seen the laptop yet?", nothing, kind="nothing"),
        # what was seen, when or where
        Ask(790, "what did you see half a minute ago?", ("scissors", "person", "reception"),
            ("red mug",), kind="seen"),
        Ask(790, "what was in front of you a minute ago", ("scissors", "reception"),
            ("red mug",), kind="seen"),
        Ask(790, "what did you see 2 min ago?", ("red mug", "kitchen", "scissors"), kind="seen"),
        Ask(700, "what do you remember seeing in the last 90 seconds",
            ("red mug", "coffee machine", "kitchen"), ("scissors",), kind="seen"),
        Ask(end, "what was in the kitchen when you were there",
            ("red mug", "coffee machine", "kitchen"), ("parcel", "scissors"), kind="seen"),
        Ask(end, "anything interesting in the last quarter hour",
            (("no record", "nothing", "dock"),), ("parcel", "red mug"), kind="seen"),
        Ask(5000, "what did you see in the past quarter of an hour",
            ("coffee machine", "red mug", "notebook", "parcel"), ("scissors", "laptop"),
            kind="seen"),
        Ask(5000, "what did you notice in the mailroom?", ("parcel", "mailroom"),
            ("laptop",), kind="seen"),
        Ask(end, "what objects were at reception?", ("scissors", "person", "reception"),
            ("parcel",), kind="seen"),
        Ask(end, "what did you see at Alice's desk", ("laptop",), ("parcel",), kind="seen"),
        # digests
        Ask(5000, "what have you been up to?", ("Evening patrol", "parcel"), kind="digest"),
        Ask(end, "anything happen in the last 20 mins?", ("dock",), ("parcel",),
            kind="digest"),
        Ask(end, "what went on during the last three hours",
            ("Fetch the red mug", "Evening patrol"), kind="digest"),
        Ask(end, "what happened between 3:30 and 3:35 pm?",
            ("meeting room", "red mug", "mailroom", "parcel"), ("scissors", "Battery"),
            kind="digest"),
        Ask(end, "where did you go in the last 3 hours",
            ("kitchen", "reception", "meeting room", "mailroom", "dock"), kind="digest"),
        # while I was away
        Ask(5000, "fill me in on what I missed", ("since you last spoke", "Evening patrol",
            "parcel"), ("scissors",), before=850, kind="away"),
        Ask(end, "I'm back, what did I miss", ("since you last spoke", "Evening patrol",
            "Battery"), ("scissors",), before=4000, kind="away"),
        Ask(790, "what's happened since I was last here?", ("since you last spoke",
            "scissors"), ("laptop",), before=715, kind="away"),
        Ask(end, "did anything happen while I was out?", ("since you last spoke",
            "Evening patrol"), before=4000, kind="away"),
        # where were you then
        Ask(end, "where were you around half past two", ("dock",), kind="pose_at"),
        Ask(end, "where were you at quarter past three", ("dock",), kind="pose_at"),
        Ask(4800, "Where were you 10 minutes ago?", ("dock",), kind="pose_at"),
        Ask(4950, "where were you five minutes ago", ("meeting room",), kind="pose_at"),
        Ask(end, "what were you up to at 14:27?", ("Fetch the red mug",), kind="pose_at"),
        Ask(end, "where were you an hour ago", ("dock",), kind="pose_at"),
        Ask(end, "where were you at 15:31", ("meeting room",), kind="pose_at"),
    ]  # fmt: skip


def fresh(shown: Shown) -> list[Ask]:
    """Written after the grammar was improved on :func:`held_out` and measured once, never
    tuned on: the honest estimate of how the layer does on wording it has not met."""
    end = DAY_S

    def ago_at(key: str, now: float = end) -> tuple[str, ...]:
        return _ago_options(START + shown[key][1], START + now)

    return [
        Ask(end, "yo, where did the scissors end up?", ("scissors", "reception"),
            kind="last_seen"),
        Ask(end, "did u see the coffee machine today", ("coffee machine", "kitchen",
            ago_at("coffee machine")), kind="last_seen"),
        Ask(end, "when did you spot my laptop last", ("laptop", ago_at("laptop")),
            kind="last_seen"),
        Ask(end, "have you noticed a cat around here?", ("no record",), kind="nothing"),
        Ask(end, "any trace of a parcel for Bob?", ("parcel", "mailroom"), kind="last_seen"),
        Ask(790, "what did you see just a moment ago?", ("person",), ("red mug",), kind="seen"),
        Ask(end, "what did you see in the mail room?", ("parcel",), ("laptop",), kind="seen"),
        Ask(end, "what things did you notice at the front desk?", ("scissors",), ("parcel",),
            kind="seen"),
        Ask(end, "tell me what happened in the past 45 minutes", (("dock", "no record"),),
            ("parcel",), kind="digest"),
        Ask(end, "where were you at noon", (("no record", "dock"),), kind="pose_at"),
        Ask(end, "where were you at ten past four", ("dock",), kind="pose_at"),
        Ask(end, "what were you doing around 3:31 in the afternoon", ("meeting room",),
            kind="pose_at"),
        Ask(5000, "so what did I miss?", ("since you last spoke", "parcel"), before=850,
            kind="away"),
        Ask(end, "and before that?", (("did not understand", "didn't understand", "dock"),),
            ("before that",), prior=("where were you an hour ago",), kind="follow_up"),
        Ask(end, "and the notebook?", ("notebook", "meeting room"),
            prior=("when did you last see the red mug?",), kind="follow_up"),
    ]  # fmt: skip


def fresh_2(shown: Shown) -> list[Ask]:
    """A second held-out set, written before the grammar was changed for :func:`fresh`'s misses
    (after which ``fresh`` is no longer held out) and never tuned on: typed and spoken wording
    over the same day (typos, chatty openers, clock words, places by their human names or the
    map's aliases, follow-ups). Benchmark only, scored apart. The day in UTC: at the dock until
    14:23, kitchen 14:23-14:25, reception 14:25-14:26, Alice's desk 14:27, dock 14:27-15:28,
    kitchen 15:28-15:30, meeting room 15:30-15:31, mailroom 15:32-15:33, dock until 17:13."""
    end = DAY_S

    def ago_at(key: str, now: float = end, which: int = 1) -> tuple[str, ...]:
        return _ago_options(START + shown[key][which], START + now)

    nothing = ("no record",)
    return [
        Ask(end, "wher did you last see the laptop?", ("laptop", ALICE, ago_at("laptop")),
            kind="last_seen"),
        Ask(end, "have you seen the scisors?", ("scissors", "reception"), kind="last_seen"),
        Ask(end, "ok so where's the red mug now?", ("red mug", "meeting room"),
            kind="last_seen"),
        Ask(end, "hey robot, quick question - did you see anyone at reception?",
            ("person", "reception"), kind="last_seen"),
        Ask(end, "when did you see the parcel for the first time?",
            ("parcel", "mailroom", ago_at("parcel#1", which=0)), kind="last_seen"),
        Ask(end, "what did you see in the post room", ("parcel", "mailroom"), ("laptop",),
            kind="seen"),
        Ask(end, "what was on Bob's desk?", nothing, ("scissors", "laptop"), kind="nothing"),
        Ask(end, "what stuff did you spot in the meeting room?", ("red mug", "notebook"),
            ("parcel",), kind="seen"),
        Ask(end, "what did you notice in the Harbour room?", ("red mug", "notebook"),
            ("parcel",), kind="seen"),
        Ask(end, "wat did you see in the kitchen", ("red mug", "coffee machine"), ("parcel",),
            kind="seen"),
        Ask(end, "what did you see at five past three", nothing, ("parcel", "red mug"),
            kind="nothing"),
        Ask(end, "where were you at quarter to four", ("dock",), kind="pose_at"),
        Ask(end, "where were you at twenty past two?", ("dock",), kind="pose_at"),
        Ask(end, "where were you at 25 past 3", ("dock",), kind="pose_at"),
        Ask(end, "where were you around midday?", nothing, kind="pose_at"),
        Ask(end, "where were you at ten to five", ("dock",), kind="pose_at"),
        Ask(end, "what happened at about 3:30 in the afternoon", ("meeting room", "red mug"),
            ("scissors", "Battery"), kind="digest"),
        Ask(5000, "so what did I miss while I was at lunch?", ("since you last spoke",
            "Evening patrol", "parcel"), ("scissors",), before=850, kind="away"),
        Ask(end, "and an hour before that?", ("meeting room",),
            prior=("where were you at 4:31 pm",), kind="follow_up"),
        Ask(end, "what about the reception?", ("scissors", "person"), ("red mug",),
            prior=("what did you see in the kitchen today",), kind="follow_up"),
    ]  # fmt: skip


def fresh_3(shown: Shown) -> list[Ask]:
    """A third held-out set, written before the grammar was changed for :func:`fresh_2`'s
    misses (after which ``fresh_2`` is tuned on) and never tuned on: present-tense "where is",
    typos, hedged and spoken clock times, follow-ups naming a place, the human names of the
    places. Benchmark only, scored apart. The day in UTC as in :func:`fresh_2`."""
    end = DAY_S

    def ago_at(key: str, now: float = end, which: int = 1) -> tuple[str, ...]:
        return _ago_options(START + shown[key][which], START + now)

    nothing = ("no record",)
    return [
        Ask(end, "where's the charger?", ("charger", "dock"), kind="last_seen"),
        Ask(end, "when did you last catch sight of the notebook?",
            ("notebook", "meeting room", ago_at("red mug")), kind="last_seen"),
        Ask(end, "did you see any people today?", ("person", "reception"), kind="last_seen"),
        Ask(end, "what did you see in the meeting room around 3:30?", ("red mug", "notebook"),
            ("parcel",), kind="seen"),
        Ask(end, "where were you at twenty five to four", ("dock",), kind="pose_at"),
        Ask(end, "what happened between 2:20 and 2:30 pm", ("kitchen", "reception",
            "scissors"), ("parcel",), kind="digest"),
        Ask(end, "have you spotted a water bottle?", nothing, kind="nothing"),
        Ask(end, "what did the robot see at the reception desk?", ("scissors", "person"),
            ("parcel",), kind="seen"),
        Ask(end, "what did you do this afternoon?", ("Fetch the red mug", "Evening patrol"),
            kind="digest"),
        Ask(end, "where were you at 14:24?", ("kitchen",), kind="pose_at"),
        Ask(end, "so when exactly did you see the laptop?",
            ("laptop", ALICE, ago_at("laptop")), kind="last_seen"),
        Ask(end, "was there anything in the kitchen at 3:29 pm?", ("coffee machine",),
            ("notebook", "parcel"), kind="seen"),
        Ask(end, "what did you see around 2:26 in the afternoon", ("scissors", "laptop"),
            ("parcel",), kind="seen"),
        Ask(end, "what about the kitchen?", ("coffee machine",), ("parcel",),
            prior=("what did you notice in the mailroom?",), kind="follow_up"),
        Ask(end, "where is the parcel?", ("parcel", "mailroom"), kind="last_seen"),
        Ask(end, "hey, when did you last see a pair of scissors", ("scissors", "reception"),
            kind="last_seen"),
        Ask(end, "anything happen around 4 pm?", (("no record", "dock"),), ("parcel",),
            kind="digest"),
        Ask(end, "where did u see the lapotp", ("laptop", ALICE), kind="last_seen"),
        Ask(end, "where were you at approximately 2:26 pm", ("reception",), kind="pose_at"),
    ]  # fmt: skip


def fresh_4(shown: Shown) -> list[Ask]:
    """A fourth held-out set, written before the grammar was changed for :func:`fresh_3`'s
    misses and never tuned on: other verbs of seeing ("catch sight of", "come across", "lay
    eyes on"), the robot named in the third person, "was there anything in P at T" and
    "anything at P earlier?", and questions memory must not answer (a place the map does not
    have, the future, what the person did): said so, never a guess or a motion. Benchmark
    only, scored apart. The day in UTC as in :func:`fresh_2`."""
    end = DAY_S

    def ago_at(key: str, now: float = end, which: int = 1) -> tuple[str, ...]:
        return _ago_options(START + shown[key][which], START + now)

    seen_things = ("charger", "red mug", "coffee machine", "scissors", "person", "laptop",
                   "parcel", "notebook")  # fmt: skip
    not_understood = (("didn't understand", "did not understand", "don't know", "can't"),)
    return [
        Ask(end, "when did you last catch sight of the parcel?",
            ("parcel", "mailroom", ago_at("parcel")), kind="last_seen"),
        Ask(end, "have you come across any scissors today?", ("scissors", "reception"),
            kind="last_seen"),
        Ask(end, "did the robot see a laptop this afternoon?", ("laptop", ALICE),
            kind="last_seen"),
        Ask(end, "did you lay eyes on the coffee machine?", ("coffee machine", "kitchen"),
            kind="last_seen"),
        Ask(end, "did you run into a parcel in the mailroom?", ("parcel", "mailroom"),
            kind="last_seen"),
        Ask(end, "where were you when you saw the notebook?", ("meeting room",),
            kind="last_seen"),
        Ask(end, "when did you first spot the parcel?",
            ("parcel", "mailroom", ago_at("parcel#1", which=0)), kind="last_seen"),
        Ask(end, "was there anything in the meeting room at 3:30 pm?", ("red mug", "notebook"),
            ("parcel", "scissors"), kind="seen"),
        Ask(end, "anything at the reception earlier?", ("scissors", "person"),
            ("coffee machine", "parcel"), kind="seen"),
        Ask(end, "what did it see in the mailroom?", ("parcel",), ("red mug", "scissors"),
            kind="seen"),
        Ask(end, "what did the bot spot at Alice's desk?", ("laptop",), ("parcel",),
            kind="seen"),
        Ask(end, "was there anything in the kitchen at about 2:24?",
            ("red mug", "coffee machine"), ("parcel", "notebook"), kind="seen"),
        Ask(end, "what did the robot see at 2:25 pm?", ("scissors",), ("parcel",), kind="seen"),
        Ask(end, "what did you see between 3:28 and 3:31 pm?",
            ("coffee machine", "red mug", "notebook"), ("parcel", "scissors"), kind="seen"),
        Ask(end, "where were you at twenty past three", ("dock",), kind="pose_at"),
        Ask(end, "did you see anything in the garage today?", (("don't know a place",
            "do not know a place"),), seen_things, kind="refuse"),
        Ask(end, "what will you see in the kitchen tomorrow?", not_understood, seen_things,
            kind="refuse"),
        Ask(end, "what did I have for lunch?", not_understood, seen_things, kind="refuse"),
    ]  # fmt: skip


class RulesChatAsker:
    """Asks each question in a new conversation of the brain's chat pipeline (rules chat)."""

    def __init__(self, day: Day, tools: EpisodicOverMcp, work: Path) -> None:
        self.day = day
        self.tools = tools
        self.work = work
        self.asked = 0
        self.understanding = Understanding()

    async def ask(self, ask: Ask) -> Asked:
        # a new mission executor per question: a misread that started a mission (counted
        # wrong: it would have moved the robot) must not leave the next question "busy"
        self.asked += 1
        harness = make_harness(self.work / f"q{self.asked}", FakeLLM())
        chat = RulesChat(self.understanding, clock=self.day.clock)
        pipeline = ChatPipeline(
            llm=chat,
            tools=self.tools,
            executor=harness.executor,
            emitter=harness.emitter,
            speech=harness.speech,
            config=ChatConfig(),
        )
        if ask.before is not None:
            self.day.clock.now = START + ask.before
            await pipeline.handle_turn("thanks, see you later")
        self.day.clock.now = START + ask.at
        for said in ask.prior:
            await pipeline.handle_turn(said)
        self.tools.calls.clear()
        result = await pipeline.handle_turn(ask.text)
        motion = [n for n, _ in self.tools.calls if not n.startswith(("episodic.", LIST_LOCATIONS))]
        return Asked(ask, result.reply, result.route, motion)


@asynccontextmanager
async def rules_chat_on_the_office_day(
    work: Path | None = None,
) -> AsyncIterator[tuple[RulesChatAsker, list[Ask]]]:
    folder = work or Path(tempfile.mkdtemp(prefix="episodic-rules-"))
    day = play_day(folder / "episodic")
    try:
        async with Client(day.app.server) as client:
            tools = await EpisodicOverMcp.connect(client)
            yield RulesChatAsker(day, tools, folder / "brain"), questions(day.shown)
    finally:
        day.app.close()


def summary(asked: list[Asked]) -> dict[str, Any]:
    by_kind: dict[str, list[int]] = {}
    for a in asked:
        counts = by_kind.setdefault(a.ask.kind, [0, 0])
        counts[0] += a.right
        counts[1] += 1
    right = sum(a.right for a in asked)
    return {
        "questions": len(asked),
        "correct": right,
        "accuracy": round(right / len(asked), 4) if asked else 0.0,
        "by_kind": {k: f"{v[0]}/{v[1]}" for k, v in sorted(by_kind.items())},
        # misreads that would move the robot: a mission started, or a motion tool called
        "would_move": [a.ask.text for a in asked if a.route != "fast" or a.motion],
        "wrong": [
            {"q": a.ask.text, "at_s": a.ask.at, "answer": a.answer,
             "missing": a.ask.wrong(a.answer), "route": a.route, "motion": a.motion}
            for a in asked if not a.right
        ],
    }  # fmt: skip


def dumps(result: dict[str, Any]) -> str:
    return json.dumps(result, indent=2, ensure_ascii=False)
