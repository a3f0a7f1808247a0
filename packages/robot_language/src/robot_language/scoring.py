"""Scoring the understanding layer on the phrasing sets (tests and benchmarks): the office map's
places as ``list_locations`` gives them, the expected codes of each instruction, and the count of
wrong actions (a reading that acts with anything but the expected sequence)."""

from __future__ import annotations

import json
import re
from collections import defaultdict
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from robot_language.commands import parse
from robot_language.config_file import CONFIG
from robot_language.listing import Locations
from robot_language.places import words

# the office map (config/office_map.yaml), as robot_mcp_navigation/config/maps/office.yaml
OFFICE_LOCATIONS: list[dict[str, Any]] = yaml.safe_load((CONFIG / "office_map.yaml").read_text())
OFFICE_LIST_LOCATIONS = json.dumps({"map": "office", "locations": OFFICE_LOCATIONS})
# every code that moves the robot or its arm (issue 38: pick, put and release act too)
ACTING = ("goto:", "find:", "fetch:", "watch:", "see", "pick", "put", "release")

Reader = Callable[[str], list[str]]


def load_set(path: Path) -> list[tuple[str, list[str]]]:
    return [
        (str(text), [str(e) for e in expected])
        for text, expected in yaml.safe_load(path.read_text())
    ]


def intent_of(expected: list[str]) -> str:
    """The intent an item tests: the first action's kind (seq when several), or its outcome."""
    return "sequence" if len(expected) > 1 else expected[0].split(":", 1)[0]


def _objects_agree(a: str, b: str) -> bool:
    wa, wb = set(words(a)), set(words(b))
    return bool(wa) and bool(wb) and (wa <= wb or wb <= wa)


def acts(codes: list[str]) -> bool:
    return any(c.startswith(ACTING) for c in codes)


def is_wrong(got: list[str], expected: list[str]) -> bool:
    """Acting with any motion/skill call the expected sequence doesn't hold, in order (an object
    worded a little differently, "person" vs "a person appears", is the same call)."""
    if not acts(got):
        return False
    if len(got) != len(expected):
        return True
    for g, e in zip(got, expected, strict=True):
        if g == e:
            continue
        gk, _, gr = g.partition(":")
        ek, _, er = e.partition(":")
        g_obj, _, g_where = gr.partition("@")
        e_obj, _, e_where = er.partition("@")
        if gk != ek or g_where != e_where or not _objects_agree(g_obj, e_obj):
            return True
    return False


@dataclass
class Score:
    total: int = 0
    understood: int = 0
    wrong: list[tuple[str, list[str], list[str]]] = field(default_factory=list)
    misses: list[tuple[str, list[str], list[str]]] = field(default_factory=list)
    per_intent: dict[str, list[int]] = field(default_factory=lambda: defaultdict(lambda: [0, 0]))

    @property
    def understood_pct(self) -> float:
        return round(100.0 * self.understood / max(self.total, 1), 1)

    def intent_accuracy(self) -> dict[str, float]:
        return {k: round(v[0] / v[1], 3) for k, v in sorted(self.per_intent.items())}


def score(items: list[tuple[str, list[str]]], read: Reader) -> Score:
    result = Score()
    for text, expected in items:
        got = read(text)
        result.total += 1
        counts = result.per_intent[intent_of(expected)]
        counts[1] += 1
        if got == expected:
            result.understood += 1
            counts[0] += 1
        else:
            result.misses.append((text, expected, got))
        if is_wrong(got, expected):
            result.wrong.append((text, expected, got))
    return result


_GREETING = re.compile(r"^(?:hi|hello|hey|hallo|good (?:morning|afternoon|evening)|howdy)\b")
_HELP = re.compile(r"\b(?:what can you do|help|what do you understand|who are you)\b")
_STOP = re.compile(r"^(?:stop|halt|freeze|stopp|arrête|fermati)\b")


def grammar_reader(text: str) -> list[str]:
    """What the grammar alone (before issue 22: rules chat + rules planner) did with ``text``."""
    clean = " ".join(text.lower().split())
    if _STOP.match(clean):
        return ["stop"]
    if _GREETING.match(clean) and len(clean.split()) <= 4:
        return ["greet"]
    if _HELP.search(clean):
        return ["answer:abilities"]
    command = parse(text)
    locations = Locations.from_result(OFFICE_LIST_LOCATIONS)
    if command.kind == "unknown":
        return ["refuse"]
    if command.kind == "see":
        return ["see"]
    if command.kind == "watch":
        return [f"watch:{command.obj}"]
    place = None
    if command.place is not None:
        place = locations.resolve(command.place)
        if place is None:
            return ["refuse"]
    if command.kind == "goto":
        return [f"goto:{place}"]
    at = f"@{place}" if place else ""
    return [f"{command.kind}:{command.obj}{at}"]
