"""The rules chat's answers to questions that need no mission (issue 32): how far and which way a
place is (from the live place list and the pose), the time, what the robot is doing."""

from __future__ import annotations

import json
import math
from datetime import datetime
from typing import Any

from robot_language.places import Place, PlaceIndex, located
from robot_voice_chat.services.llm.rules.recollection import names_of

NOTHING_TO_CONTINUE = "There's nothing to continue: no mission is paused. Tell me what to do next."
_SIDES = [  # (largest |bearing| in degrees, how it is said); left is positive (ROS REP 103)
    (22.5, "straight ahead of me"),
    (67.5, "ahead of me on the {side}"),
    (112.5, "on my {side}"),
    (157.5, "behind me on the {side}"),
    (180.0, "behind me"),
]


def clock_sentence(now: float) -> str:
    """ "It's 3:05 pm." in the robot's local time."""
    moment = datetime.fromtimestamp(now).astimezone()
    hour = moment.hour % 12 or 12
    return f"It's {hour}:{moment.minute:02d} {'am' if moment.hour < 12 else 'pm'}."


def _pose(content: str, is_error: bool) -> dict[str, Any] | None:
    if is_error:
        return None
    try:
        pose = json.loads(content)
    except ValueError:
        return None
    return pose if isinstance(pose, dict) else None


def doing_sentence(content: str | None, is_error: bool, names: PlaceIndex | None) -> str:
    """What the robot is doing when no mission runs (a mission's own turns are answered by it)."""
    pose = _pose(content, is_error) if content is not None else None
    say = names_of(names)
    if pose and pose.get("moving") and pose.get("destination"):
        return f"No mission of mine is running, but I'm driving to {say(str(pose['destination']))}."
    if pose and pose.get("at_location"):
        where = located(say(str(pose["at_location"])))
        return f"Nothing right now: I'm {where}, waiting for a task."
    return "Nothing right now: no mission is running. Tell me what to do."


def distance_sentence(
    place: Place, content: str | None, is_error: bool, names: PlaceIndex | None
) -> str:
    """How far ``place`` is and which way, from the pose (x, y, theta) and the place's map
    position; without a pose, the distance list_locations gave."""
    say = names_of(names)
    spoken = say(place.name)
    subject = spoken[:1].upper() + spoken[1:]
    pose = _pose(content, is_error) if content is not None else None
    if pose is not None and pose.get("at_location") == place.name:
        return f"I'm {located(spoken)} right now."
    here = _xy(pose)
    distance = place.distance_m
    way = ""
    if here is not None and place.x is not None and place.y is not None:
        dx, dy = place.x - here[0], place.y - here[1]
        distance = math.hypot(dx, dy)
        theta = pose.get("theta") if pose is not None else None
        if isinstance(theta, int | float) and distance > 0.3:
            way = ", " + _side(math.degrees(math.atan2(dy, dx) - theta))
    if distance is None:
        return f"I can't tell how far {spoken} is: I have no position for it or for me."
    eta = f" (about {round(place.eta_s)} s of driving)" if place.eta_s else ""
    return f"{subject} is about {distance:.0f} m from here{way}{eta}."


def _side(degrees: float) -> str:
    bearing = (degrees + 180.0) % 360.0 - 180.0
    side = "left" if bearing > 0 else "right"
    return next(said for most, said in _SIDES if abs(bearing) <= most).format(side=side)


def _xy(pose: dict[str, Any] | None) -> tuple[float, float] | None:
    if pose is None:
        return None
    x, y = pose.get("x"), pose.get("y")
    if isinstance(x, int | float) and isinstance(y, int | float):
        return float(x), float(y)
    return None
