"""The robot-words checker over what issue 39 makes the robot say (extends
test_rvc_robot_words.py): what it holds, where it is — a named place, never map coordinates —
and which part of it a lost server leaves stopped — the arm or the base, never a server's
name. The checker's two new kinds, the sentence templates fed every office place, and the
carrying missions of the simulated office, collected from what the fakes were asked to say."""

from __future__ import annotations

import asyncio
import json
import time
from collections.abc import Callable
from pathlib import Path

import pytest

from robot_language.places import PlaceIndex
from robot_language.scoring import OFFICE_LIST_LOCATIONS
from robot_stack_testing.brain.office import Office, office
from robot_voice_chat.agent.supervision_words import lost_motion_server, unconfirmed_stop
from robot_voice_chat.held_words import holding_answer, still_holding, whereabouts_of
from robot_voice_chat.robot_words import check_robot_words, leaks, witnessing

OFFICE_PLACES = PlaceIndex.from_result(OFFICE_LIST_LOCATIONS)


@pytest.mark.parametrize(
    ("sentence", "kind"),
    [
        ("I'm still holding the yellow package, near (14.0, 6.0).", "coordinates"),
        ("I'm holding it at x=14.2, y=6.0.", "coordinates"),
        ("I stopped at pose (3.5, -1.0) on the way.", "coordinates"),
        ("So the robot's manipulation holds itself stopped.", "server name"),
        ("I lost contact with my skill control.", "server name"),
    ],
)
def test_the_checker_finds_coordinates_and_server_names(sentence: str, kind: str) -> None:
    assert kind in [leak.kind for leak in leaks(sentence)], leaks(sentence)


@pytest.mark.parametrize(
    "sentence",
    [
        "I'm still holding the yellow package, near the east corridor. Should I put it down "
        "here, or take it somewhere?",
        "I lost contact with my arm. My supervision of it lapsed at 14:03:12, so the robot's "
        "arm holds itself stopped. I'm waiting for the server to come back.",
        "I found the package in the mailroom: yellow package (0.91, 0.88).",
        "Reception is about 12 m from here (about 15 s of driving).",
    ],
)
def test_plain_sentences_about_holding_and_parts_pass(sentence: str) -> None:
    assert leaks(sentence) == []


# --- every template, fed every office place and both motion servers -------------------------
FETCH_PACKAGE = "fetch the package from the mailroom and bring it to reception"


def _held_where(name: str) -> str:
    """The robot near ``name`` (3 m), as the real navigation server's distances put it."""
    listed = {"locations": [{**p, "distance_m": 3.0 if p["name"] == name else 20.0}
                            for p in json.loads(OFFICE_LIST_LOCATIONS)["locations"]]}  # fmt: skip
    return still_holding("yellow package", whereabouts_of(json.dumps(listed)))


class _Lapsed:
    async def settle(self, server: str) -> tuple[str, float]:
        return "lapsed", time.time()


HELD_TEMPLATES: list[tuple[str, Callable[[], str]]] = [
    *(
        (f"still holding near {p.name}", lambda n=p.name: _held_where(n))
        for p in OFFICE_PLACES.places
    ),
    ("still holding, nowhere known", lambda: still_holding("red mug", None)),
    ("a search answered from the gripper", lambda: holding_answer("yellow package")),
    *(
        (f"lost {server}", lambda s=server: asyncio.run(lost_motion_server(_Lapsed(), s)))  # type: ignore[arg-type]
        for server in ("navigation", "manipulation")
    ),
    *(
        (
            f"unconfirmed stop of {server}",
            lambda s=server: asyncio.run(unconfirmed_stop(_Lapsed(), s)),
        )  # type: ignore[arg-type]
        for server in ("navigation", "manipulation")
    ),
]


@pytest.mark.parametrize(("name", "template"), HELD_TEMPLATES, ids=[n for n, _ in HELD_TEMPLATES])
def test_what_the_robot_says_it_holds_and_which_part_is_stopped_is_plain(
    name: str, template: Callable[[], str]
) -> None:
    said = template()
    assert said
    assert leaks(said) == [], said
    assert "_" not in said


def _carry_blocked(o: Office) -> None:
    o.world.door_closed = False
    o.world.distances = True
    o.world.unreachable = {"reception"}


def _pick_lost_after_grasp(o: Office) -> None:
    o.world.door_closed = False
    o.world.arm.lost_after_grasp = True


def _already_held(o: Office) -> None:
    o.world.arm.held = "yellow package"
    o.world.objects["mailroom"].remove("yellow package")
    o.world.at, o.world.distances = "corridor_b", True


CARRY_FAILURES: list[tuple[str, Callable[[Office], None], str]] = [
    ("a carry that cannot arrive", _carry_blocked, FETCH_PACKAGE),
    ("a pick lost after the grasp", _pick_lost_after_grasp, FETCH_PACKAGE),
    ("a search for what is held", _already_held, "find the yellow package in the mailroom"),
    ("a fetch of what is held", _already_held, FETCH_PACKAGE),
    ("a drive while holding that fails", _carry_blocked, "go to the reception"),
]


@pytest.mark.parametrize(
    ("name", "setup", "request_text"), CARRY_FAILURES, ids=[f[0] for f in CARRY_FAILURES]
)
async def test_what_the_robot_says_about_what_it_carries_is_plain(
    tmp_path: Path, name: str, setup: Callable[[Office], None], request_text: str
) -> None:
    o = office(tmp_path, arm=True)
    setup(o)
    if name == "a drive while holding that fails":
        o.world.arm.held = "red mug"
    with witnessing() as said:
        mission = await o.run(request_text)
    assert mission.summary in said
    assert check_robot_words(said) == [], said
