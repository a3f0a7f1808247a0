"""A scripted, time-compressed office day (3 h of robot time replayed in well under a second)
and the questions about it with their known answers: shared by the tests and by
``benchmarks/episodic_accuracy.py``. Deterministic: a fake clock, no randomness, no sleeps.

The day (seconds after ``start``): missions m-1 (fetch: kitchen -> reception -> Alice's desk,
0-850 s) and m-2 (patrol: kitchen, meeting room, mailroom, 4500-4950 s); the robot idles at
the dock in between ("while you were away") and until the end at 10 800 s. The red mug is in
the kitchen during m-1 and gone from there during m-2 (absence evidence), then seen in the
meeting room. The parcel is seen twice in the mailroom with a gap (two intervals).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from robot_mcp_episodic.ingest import Indexer
from robot_mcp_episodic.places import Places
from robot_mcp_episodic.timeparse import ago, iso

SPEED_MPS = 0.8
POSE_HZ = 2.0
FRAME_HZ = 2.0
IDLE_POSE_S = 5.0
DAY_S = 10_800.0


class ManualClock:
    def __init__(self, now: float) -> None:
        self.now = now

    def __call__(self) -> float:
        return self.now


class Episode:
    """Feeds an :class:`Indexer` as the ROS side would, moving a fake clock forward."""

    def __init__(self, indexer: Indexer, places: Places, clock: ManualClock) -> None:
        self.indexer = indexer
        self.places = places
        self.clock = clock
        self.start = clock.now
        self.x = 0.0
        self.y = 0.0
        self.yaw = 0.0
        self.events = 0

    def at(self, offset: float) -> float:
        return self.start + offset

    def _pose(self) -> None:
        self.indexer.on_pose(self.clock.now, self.x, self.y, self.yaw)
        self.events += 1

    def idle_until(self, offset: float) -> None:
        while self.clock.now + IDLE_POSE_S <= self.at(offset):
            self.clock.now += IDLE_POSE_S
            self._pose()
        self.clock.now = self.at(offset)
        self._pose()

    def drive_to(self, place: str) -> None:
        target = self.places.position(place)
        distance = math.hypot(target[0] - self.x, target[1] - self.y)
        self.yaw = math.atan2(target[1] - self.y, target[0] - self.x)
        steps = max(1, math.ceil(distance / SPEED_MPS * POSE_HZ))
        x0, y0 = self.x, self.y
        for step in range(1, steps + 1):
            self.clock.now += 1.0 / POSE_HZ
            self.x = x0 + (target[0] - x0) * step / steps
            self.y = y0 + (target[1] - y0) * step / steps
            self._pose()

    def look(
        self, seconds: float, skill: str, labels: Sequence[str], score: float = 0.8
    ) -> tuple[float, float]:
        """``skill`` publishes frames for ``seconds``; each shows ``labels`` (maybe none).
        Returns the (first, last) frame times: the ground truth of when they were shown."""
        frames = int(seconds * FRAME_HZ)
        first = self.clock.now + 1.0 / FRAME_HZ
        for frame in range(frames):
            self.clock.now += 1.0 / FRAME_HZ
            wobble = 0.05 * math.sin(frame)
            detections = [
                {"label": label, "score": round(score + wobble, 3),
                 "box": {"x": 100 + frame, "y": 80, "width": 60, "height": 40}}
                for label in labels
            ]  # fmt: skip
            self.indexer.on_detections(skill, self.clock.now, detections)
            self.events += 1
            if frame % int(FRAME_HZ) == 0:
                self._pose()
        return first, self.clock.now

    def note(self, kind: str, text: str, mission_id: str | None = None) -> None:
        self.indexer.note(kind, text, mission_id)


def play_office_day(episode: Episode) -> dict[str, tuple[float, float]]:
    """Plays the day; returns when each thing was shown (offsets from the start)."""
    e = episode
    shown: dict[str, tuple[float, float]] = {}

    def look(key: str, seconds: float, skill: str, labels: Sequence[str]) -> None:
        first, last = e.look(seconds, skill, labels)
        shown[key] = (first - e.start, last - e.start)

    e.idle_until(0)
    look("charger", 30, "detect", ["charger"])
    e.idle_until(60)
    e.note("mission_started", "Fetch the red mug for Alice", "m-1")
    e.note("user", "Please bring me my red mug, I think it is in the kitchen", "m-1")
    e.idle_until(600)
    e.drive_to("kitchen")
    e.idle_until(620)
    look("red mug@kitchen", 60, "detect", ["red mug", "coffee machine"])
    e.note("scene", "A red mug stands next to the coffee machine on the counter", "m-1")
    e.idle_until(700)
    e.drive_to("reception")
    e.idle_until(720)
    look("scissors", 40, "detect", ["scissors"])
    look("person", 20, "people", ["person"])
    e.note("user", "Please bring the scissors to Alice as well", "m-1")
    e.idle_until(800)
    e.drive_to("desk_alice")
    e.idle_until(820)
    look("laptop", 20, "detect", ["laptop"])
    e.note("robot", "Here are your mug and the scissors, Alice", "m-1")
    e.note("mission_finished", "Fetch finished: mug and scissors delivered", "m-1")
    e.drive_to("dock")
    e.idle_until(4500)
    e.note("mission_started", "Evening patrol of the office", "m-2")
    e.drive_to("kitchen")
    look("coffee machine", 40, "detect", ["coffee machine"])
    e.idle_until(4600)
    e.drive_to("meeting_room")
    look("red mug", 30, "detect", ["red mug", "notebook"])
    e.idle_until(4700)
    e.drive_to("mailroom")
    look("parcel#1", 10, "detect", ["parcel"])
    e.look(10, "detect", [])
    e.idle_until(4800)
    look("parcel", 10, "detect", ["parcel"])
    e.note("scene", "A large parcel for Bob lies on the mailroom shelf", "m-2")
    e.drive_to("dock")
    e.note("mission_finished", "Patrol finished, nothing unusual", "m-2")
    e.idle_until(7200)
    e.note("robot", "Battery at 80 percent, staying at the dock")
    e.idle_until(DAY_S)
    return shown


# -- the question set ---------------------------------------------------------------------
Check = Callable[[dict[str, Any]], bool]


@dataclass(frozen=True)
class Question:
    text: str
    tool: str
    args: dict[str, Any]
    check: Check


def _near(value: float, expected: float, tolerance: float = 1.0) -> bool:
    return abs(value - expected) <= tolerance


def questions(start: float, now: float, shown: dict[str, tuple[float, float]]) -> list[Question]:
    """The questions with known answers (``start``: the episode's start; ``now``: its end;
    ``shown``: what :func:`play_office_day` showed when)."""

    def at(offset: float) -> float:
        return start + offset

    q: list[Question] = []

    def last_seen(label: str, place: str, key: str | None = None, **args: Any) -> None:
        first, last = shown[key or label]

        def top(answer: dict[str, Any]) -> dict[str, Any]:
            return answer["results"][0] if answer.get("results") else {}

        base = {"query": label, **args}
        q.append(Question(
            f"where did you last see the {label}?", "last_seen", base,
            lambda a: top(a).get("place") == place,
        ))  # fmt: skip
        q.append(Question(
            f"when did you last see the {label}?", "last_seen", base,
            lambda a: _near(top(a).get("last_seen", {}).get("t", 0), at(last), 1.0)
            and top(a)["last_seen"]["time"] == iso(top(a)["last_seen"]["t"]),
        ))  # fmt: skip
        q.append(Question(
            f"how long ago did you see the {label}?", "last_seen", base,
            lambda a: top(a).get("last_seen", {}).get("ago")
            in {ago(at(last) + d, now) for d in (-1, -0.5, 0, 0.5, 1)},
        ))  # fmt: skip
        q.append(Question(
            f"when did you first see the {label} that time?", "last_seen", base,
            lambda a: _near(top(a).get("first_seen", {}).get("t", 0), at(first), 1.0),
        ))  # fmt: skip

    last_seen("charger", "dock")
    last_seen("red mug", "meeting_room", n=1)
    last_seen("coffee machine", "kitchen")
    last_seen("scissors", "reception")
    last_seen("person", "reception")
    last_seen("laptop", "desk_alice")
    # the second parcel interval; the first one keeps its own first seen
    last_seen("parcel", "mailroom")
    # the red mug before the patrol: it was in the kitchen
    last_seen("mug", "kitchen", "red mug@kitchen", before=iso(at(1000)))

    def answer_has(text: str) -> Check:
        return lambda a: text in a.get("answer", "")

    for label in ("umbrella", "giraffe", "bicycle", "cat"):
        q.append(Question(
            f"when did you last see the {label}?", "last_seen", {"query": label},
            lambda a: a.get("found") is False and a.get("results") == [],
        ))  # fmt: skip
        q.append(Question(
            f"did you see a {label}? (says so)", "last_seen", {"query": label},
            answer_has("no record"),
        ))  # fmt: skip
    q.append(Question(
        "did you see the scissors before 10 minutes in?", "last_seen",
        {"query": "scissors", "before": iso(at(600))}, lambda a: a["found"] is False,
    ))  # fmt: skip
    q.append(Question(
        "is the red mug still in the kitchen?", "last_seen",
        {"query": "red mug", "place": "kitchen"},
        lambda a: a["results"][0]["absent_since"] is not None
        and _near(a["results"][0]["absent_since"]["t"], at(shown["coffee machine"][0]), 1.0),
    ))  # fmt: skip
    q.append(Question(
        "is the red mug still in the meeting room?", "last_seen",
        {"query": "red mug", "place": "meeting room"},
        lambda a: a["results"][0]["absent_since"] is None,
    ))  # fmt: skip
    q.append(Question(
        "how many times did you see the parcel?", "last_seen", {"query": "parcel", "n": 5},
        lambda a: len(a["results"]) == 2
        and _near(a["results"][1]["first_seen"]["t"], at(shown["parcel#1"][0]), 1.0)
        and _near(a["results"][0]["first_seen"]["t"], at(shown["parcel"][0]), 1.0),
    ))  # fmt: skip
    q.append(Question(
        "how long did you see the scissors?", "last_seen", {"query": "scissors"},
        lambda a: _near(
            a["results"][0]["seen_for_s"], shown["scissors"][1] - shown["scissors"][0], 0.01
        ),
    ))  # fmt: skip
    q.append(Question(
        "which skill saw the person?", "last_seen", {"query": "person"},
        lambda a: a["results"][0]["skill"] == "people",
    ))  # fmt: skip
    q.append(Question(
        "where was the robot when it saw the laptop?", "last_seen", {"query": "laptop"},
        lambda a: _near(a["results"][0]["robot_pose"]["x"], 6.0, 0.01)
        and _near(a["results"][0]["robot_pose"]["y"], 8.0, 0.01),
    ))  # fmt: skip

    def kinds_of(answer: dict[str, Any]) -> set[str]:
        return {item["kind"] for item in answer.get("items", [])}

    def labels_of(answer: dict[str, Any]) -> set[str]:
        return {item.get("label") for item in answer.get("items", []) if item["kind"] == "sighting"}

    q.append(Question(
        "what did you see in the last 10 minutes?", "what_happened",
        {"start": "-10m", "kinds": ["sightings"]}, lambda a: a["items"] == [],
    ))  # fmt: skip
    q.append(Question(
        "what did you see in the last 10 minutes? (says nothing)", "what_happened",
        {"start": "-10m", "kinds": ["sightings"]},
        lambda a: a["summary"].startswith("Nothing was recorded"),
    ))  # fmt: skip
    q.append(Question(
        "what happened while I was away (after the fetch)?", "what_happened",
        {"start": iso(at(900)), "end": iso(at(4400)),
         "kinds": ["sightings", "missions", "conversation"]},
        lambda a: a["items"] == [],
    ))  # fmt: skip
    q.append(Question(
        "what happened in the last 3 hours? (both missions)", "what_happened",
        {"start": "-3h", "kinds": ["missions"]},
        lambda a: [i["mission_id"] for i in a["items"]] == ["m-1", "m-1", "m-2", "m-2"],
    ))  # fmt: skip
    q.append(Question(
        "what did you see during the patrol?", "what_happened",
        {"start": iso(at(4500)), "end": iso(at(4950)), "kinds": ["sightings"]},
        lambda a: labels_of(a) == {"coffee machine", "red mug", "notebook", "parcel"},
    ))  # fmt: skip
    q.append(Question(
        "what did you see in the kitchen?", "what_happened",
        {"start": "-3h", "kinds": ["sightings"], "place": "kitchen"},
        lambda a: labels_of(a) == {"red mug", "coffee machine"},
    ))  # fmt: skip
    q.append(Question(
        "what did people say?", "what_happened",
        {"start": "-3h", "kinds": ["conversation"]},
        lambda a: len(a["items"]) == 4 and kinds_of(a) == {"user", "robot"},
    ))  # fmt: skip
    q.append(Question(
        "where did you go during the fetch?", "what_happened",
        {"start": iso(at(590)), "end": iso(at(shown["laptop"][1])), "kinds": ["places"]},
        lambda a: [i["place"] for i in a["items"]]
        == ["dock", "kitchen", "reception", "desk_alice"],
    ))  # fmt: skip
    q.append(Question(
        "what did you see a minute into the fetch at reception?", "what_happened",
        {"start": iso(at(715)), "end": iso(at(765)), "kinds": ["sightings"]},
        lambda a: labels_of(a) == {"scissors", "person"},
    ))  # fmt: skip
    q.append(Question(
        "what did you see 30 seconds after start?", "what_happened",
        {"start": iso(at(20)), "end": iso(at(40)), "kinds": ["sightings"]},
        lambda a: labels_of(a) == {"charger"},
    ))  # fmt: skip
    q.append(Question(
        "what happened in the last 30 minutes?", "what_happened", {"start": "-30m"},
        lambda a: kinds_of(a) == {"visit"} and a["items"][0]["place"] == "dock",
    ))  # fmt: skip
    q.append(Question(
        "what happened in the last hour?", "what_happened", {"start": "-1h"},
        lambda a: kinds_of(a) == {"visit", "robot"}
        and any("Battery" in i["text"] for i in a["items"]),
    ))  # fmt: skip
    q.append(Question(
        "what did you note in the mailroom?", "what_happened",
        {"start": "-3h", "kinds": ["scene"], "place": "mailroom"},
        lambda a: len(a["items"]) == 1 and "parcel" in a["items"][0]["text"],
    ))  # fmt: skip

    def pose_question(offset: float, place: str | None, mission: str | None) -> None:
        q.append(Question(
            f"where were you at +{offset:.0f} s?", "pose_at", {"time": iso(at(offset))},
            lambda a: a["found"] and a["place"] == place,
        ))  # fmt: skip
        q.append(Question(
            f"which mission ran at +{offset:.0f} s?", "pose_at", {"time": iso(at(offset))},
            lambda a: (a["mission"] or {}).get("mission_id") == mission,
        ))  # fmt: skip

    pose_question(650, "kitchen", "m-1")
    pose_question(740, "reception", "m-1")
    pose_question(830, "desk_alice", "m-1")
    pose_question(3000, "dock", None)
    pose_question(4640, "meeting_room", "m-2")
    pose_question(4805, "mailroom", "m-2")
    q.append(Question(
        "where were you 2 hours ago?", "pose_at", {"time": "-2h"},
        lambda a: a["found"] and a["place"] == "dock",
    ))  # fmt: skip
    q.append(Question(
        "where were you just now?", "pose_at", {"time": "now"},
        lambda a: a["found"] and a["place"] == "dock" and a["mission"] is None,
    ))  # fmt: skip

    def search(query: str, check: Check, **args: Any) -> None:
        q.append(Question(f"search: {query}", "search_memory", {"query": query, **args}, check))

    def first_text(answer: dict[str, Any]) -> str:
        return str(answer["results"][0]["text"]) if answer.get("results") else ""

    search("coffee machine", lambda a: "coffee machine" in first_text(a))
    search("scissors Alice", lambda a: any("scissors" in r["text"] for r in a["results"][:2]))
    search("battery", lambda a: "Battery" in first_text(a))
    search("parcel", lambda a: "parcel" in first_text(a))
    search("unicorn", lambda a: a["found"] is False)
    search("parcel", lambda a: all(r.get("place") == "mailroom" for r in a["results"]),
           place="mailroom")  # fmt: skip
    search("mug", lambda a: all(r["t"] <= at(1000) for r in a["results"]) and a["found"],
           end=iso(at(1000)))  # fmt: skip
    search("patrol", lambda a: "patrol" in first_text(a).lower())
    return q
