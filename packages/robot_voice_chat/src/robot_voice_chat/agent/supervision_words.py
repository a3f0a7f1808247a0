"""What the brain says about a motion server it cannot reach (issue 27): what the world shows,
never "Stopped." about a motion it could not stop.

The chain a sentence relies on: a motion server without a fresh lease from the brain cancels
its motion and locks the robot's base (its dead-man lock on the robot's twist_mux); a dead
server's lock falls silent, which twist_mux reads as locked. So once the brain's lease on a
server has surely run out, the robot's base holds itself stopped — and only then is it said.
"""

from __future__ import annotations

import time

from robot_voice_chat.control.supervisor import MotionSupervisor
from robot_voice_chat.robot_words import service_name


def _clock(wall: float) -> str:
    return time.strftime("%H:%M:%S", time.localtime(wall))


async def unconfirmed_stop(supervisor: MotionSupervisor | None, server: str) -> str:
    """One sentence for a motion server that did not confirm a stop."""
    name = service_name(server)
    if supervisor is not None:
        outcome, when = await supervisor.settle(server)
        if outcome == "lapsed":
            return (
                f"I could not reach my {name}, so it could not confirm the stop. "
                f"My supervision of it lapsed at {_clock(when)}, and without supervision the "
                "robot's base holds itself stopped."
            )
        if outcome == "latched":
            return (
                f"My {name} did not confirm the stop, but it has taken the software stop, "
                "which holds the robot's base stopped."
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
                f"{_clock(when)}, so the robot's base holds itself stopped. I'm waiting for "
                "the server to come back."
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
