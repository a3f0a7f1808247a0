"""What the brain says about a motion server it cannot reach (issue 27): what the world shows,
never "Stopped." about a motion it could not stop.

The chain a sentence relies on: a motion server without a fresh lease from the brain cancels
its motion and locks its own part of the robot — navigation the base (its dead-man lock on the
robot's twist_mux), manipulation the arm (its lock on the arm controller's command gate); a dead
server's lock falls silent, which reads as locked. So once the brain's lease on a server has
surely run out, that part holds itself stopped — and only then is it said, naming the part the
lock holds (issue 39: never "the base" for a lost arm server while the arm could move).
"""

from __future__ import annotations

import time

from robot_voice_chat.control.supervisor import MotionSupervisor
from robot_voice_chat.robot_words import service_name

PARTS = {"navigation": "base", "manipulation": "arm"}
"""The part of the robot each motion server's dead-man lock holds."""


def _clock(wall: float) -> str:
    return time.strftime("%H:%M:%S", time.localtime(wall))


def held_part(servers: list[str] | tuple[str, ...] | set[str]) -> str:
    """ "the robot's base", "the robot's arm", or "the robot's base and arm": the parts the
    locks of ``servers`` hold (a motion server of another kind: its own name)."""
    parts = list(dict.fromkeys(PARTS.get(s, service_name(s)) for s in sorted(servers)))
    parts.sort(key=lambda p: (p != "base", p))
    return "the robot's " + " and ".join(parts)


def _holds(servers: list[str]) -> str:
    verb = "holds itself" if len(servers) == 1 else "hold themselves"
    return f"{held_part(servers)} {verb} stopped"


async def unconfirmed_stop(supervisor: MotionSupervisor | None, server: str) -> str:
    """One sentence for a motion server that did not confirm a stop."""
    name = service_name(server)
    if supervisor is not None:
        outcome, when = await supervisor.settle(server)
        if outcome == "lapsed":
            return (
                f"I could not reach my {name}, so it could not confirm the stop. "
                f"My supervision of it lapsed at {_clock(when)}, and without supervision "
                f"{_holds([server])}."
            )
        if outcome == "latched":
            return (
                f"My {name} did not confirm the stop, but it has taken the software stop, "
                f"which holds {held_part([server])} stopped."
            )
    return (
        f"I could not reach my {name}, so I cannot confirm that the robot stopped. If it "
        "still moves, press the stop button on the robot itself."
    )


async def lost_motion_server(supervisor: MotionSupervisor | None, server: str) -> str:
    """What to tell the person when a motion server with live tasks went away."""
    name = service_name(server)
    if supervisor is not None:
        outcome, when = await supervisor.settle(server)
        if outcome == "lapsed":
            return (
                f"I lost contact with my {name}. My supervision of it lapsed at "
                f"{_clock(when)}, so {_holds([server])}. I'm waiting for the server to come "
                "back."
            )
    return (
        f"I lost contact with my {name} and am waiting for it to come back. I cannot tell "
        "whether the robot is still moving: if it is, press the stop button on the robot itself."
    )


def stop_hint(supervisor: MotionSupervisor | None) -> str:
    """ "Say stop to halt me." — only while every motion server answers the brain."""
    if supervisor is None or supervisor.all_fresh():
        return " Say stop to halt me."
    return ""
