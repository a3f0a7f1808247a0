"""What the robot says is plain words (issue 31): no task ids, tool names, error codes,
snake_case ids or raw server strings in anything said or shown as the robot's words (mission
summaries, chat replies, spoken lines); codes stay in step details and logs. Issue 39 adds the
robot's whereabouts (a named place, never map coordinates) and its parts (the arm, the base,
never a server's name).

:func:`leaks` is the one checker: the unit sweep over the sentence templates and the e2e tests
call it on every reply they see, so a new sentence that leaks is caught wherever it comes from.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass

from robot_voice_chat.socket_events import (
    ChatError,
    ChatMessage,
    MissionEventLine,
    MissionFinished,
    SocketEvent,
    Speak,
)

_SERVERS = r"navigation|perception|skill_control|memory|episodic|manipulation|vision"
_PATTERNS: tuple[tuple[str, re.Pattern[str]], ...] = (
    # nav-7f5d78a8, m-78e8a4, watch-1: a word, a hyphen and an id holding a digit
    ("task id", re.compile(r"\b[a-z]{1,12}-(?=[0-9a-z]*\d)[0-9a-z]{1,16}\b")),
    # navigation.navigate_to, skill_control.stop_skill, navigation__navigate_to
    (
        "tool name",
        re.compile(
            rf"\b(?:{_SERVERS})\.[a-z_]+\b|\b[a-z]+(?:_[a-z]+)*\.[a-z]+(?:_[a-z]+)+\b|\b\w+__\w+\b"
        ),
    ),
    # SAFETY_STOP_LATCHED, DOOR_CLOSED, NAVIGATION_TIMEOUT
    ("error code", re.compile(r"\b[A-Z][A-Z0-9]+(?:_[A-Z0-9]+)+\b")),
    # desk_alice, corridor_b, invalid_time, navigate_to
    ("snake_case id", re.compile(r"\b[A-Za-z0-9]+(?:_[A-Za-z0-9]+)+\b")),
    # JSON, Python reprs and the tool backend's own "error: ..." lines
    (
        "raw server text",
        re.compile(
            r"[{\[]\s*[\"']|[\"']\w+[\"']\s*:|\b\w+(?:Error|Exception)\b|\berror:|Traceback",
        ),
    ),
    # the software inside the robot by its engineers' names ("Nav2 found no path", "on the
    # costmap", "the behaviour tree"): a person hears what the robot could not do
    (
        "engineering name",
        re.compile(r"\bNav2\b|\bcostmaps?\b|\bbehaviou?r tree\b|\bbt_navigator\b", re.I),
    ),
    # "Nav2 error 208", "error code 42": a number only an engineer can read
    ("error number", re.compile(r"\berror(?: code)? \d{2,}\b", re.IGNORECASE)),
    # "for 0 s", "0 s ago", "0.0 s ago": under a second is "just now"
    ("zero seconds", re.compile(r"(?<![\d.])0(?:\.0+)? ?s(?:ec(?:onds?)?)?\b")),
    # a software stop is a software stop
    ("emergency stop", re.compile(r"\bemergency[ -]stop|\be-stop\b", re.IGNORECASE)),
    # where the robot is, as a person says it (issue 39): a named place, never the map's
    # numbers ("near (14.0, 6.0)", "at x=14.0", "theta: 1.57")
    (
        "coordinates",
        re.compile(
            r"\b(?:near|at|around|to|from|pose|position)\s+\(\s*-?\d+(?:\.\d+)?\s*,\s*-?\d"
            r"|\b(?:x|y|theta)\s*[=:]\s*-?\d"
        ),
    ),
    # a part of the robot by its server's name ("the robot's manipulation holds itself
    # stopped", "my skill control"): the arm, the base, the camera skills
    (
        "server name",
        re.compile(
            r"\b(?:robot's|its|my) (?:manipulation|skill[ _]control|perception[ _]buffer)\b"
            r"|\brobot's (?:navigation|episodic)\b",
            re.IGNORECASE,
        ),
    ),
)


SERVICES = {
    "navigation": "navigation",
    "skill_control": "camera skills",
    "perception": "camera",
    "vision": "camera",
    "episodic": "episodic memory",
    "memory": "process memory",
    "manipulation": "arm",
}


def service_name(server: str) -> str:
    """``skill_control`` → "camera skills": an MCP server as the robot names it."""
    return SERVICES.get(server, server.replace("_", " "))


def plain_instruction(text: str) -> str:
    """An instruction echoed back to a person: the grammar's map ids with spaces."""
    return re.sub(r"\b([A-Za-z0-9]+)_(?=[A-Za-z0-9])", r"\1 ", text)


@dataclass(frozen=True)
class Leak:
    kind: str  # "task id", "tool name", "error code", "snake_case id", ...
    text: str  # what leaked
    sentence: str

    def __str__(self) -> str:
        return f"{self.kind} {self.text!r} in {self.sentence!r}"


def leaks(sentence: str) -> list[Leak]:
    """Everything in ``sentence`` that is not for a person to hear (empty when it is clean)."""
    found: list[Leak] = []
    taken: list[tuple[int, int]] = []
    for kind, pattern in _PATTERNS:
        for match in pattern.finditer(sentence):
            span = match.span()
            if any(a < span[1] and span[0] < b for a, b in taken):
                continue  # one leak, reported once (a code is also snake-ish)
            taken.append(span)
            found.append(Leak(kind, match.group(0), sentence))
    return found


def check_robot_words(sentences: list[str] | tuple[str, ...]) -> list[Leak]:
    """The leaks of every sentence (tests: ``assert not check_robot_words(said)``)."""
    return [leak for sentence in sentences for leak in leaks(sentence)]


def sentences_of(event: SocketEvent) -> list[str]:
    """What an event shows or says as the robot's words (chat replies, spoken and said
    lines, mission summaries); plan steps, tool calls and task events are not."""
    if isinstance(event, ChatMessage) and event.role == "assistant":
        return [event.text]
    if isinstance(event, MissionEventLine) and event.kind == "say":
        return [event.text]
    if isinstance(event, MissionFinished):
        return [event.summary]
    if isinstance(event, ChatError):
        return [event.message]
    if isinstance(event, Speak):
        return [event.text]
    return []


# The fakes of the speech and emitter ports report what the robot said here, so a test run
# can check every sentence its scenario produced (tests/conftest.py).
_witnessed: list[str] | None = None


def witness(sentences: list[str]) -> None:
    if _witnessed is not None:
        _witnessed.extend(sentences)


@contextmanager
def witnessing() -> Iterator[list[str]]:
    """Collect everything the fakes were asked to say or show within the block."""
    global _witnessed
    previous, _witnessed = _witnessed, []
    try:
        yield _witnessed
    finally:
        _witnessed = previous
