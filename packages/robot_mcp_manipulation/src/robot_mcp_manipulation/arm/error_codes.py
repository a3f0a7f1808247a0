"""The Pick/Place actions' error codes (``robot_manipulation_interfaces``) → the named failures
the planner reads, with ``recoverable`` and what to try. The README renders this table; a test
keeps the two equal."""

from __future__ import annotations

from typing import Literal

from robot_mcp_kit.motion_errors import NamedFailure, by_code

Action = Literal["pick", "place"]


_LOOK_AGAIN = "look again (find_object), then call pick with the new detection's mask_ref"
_OPERATOR = "ask an operator to check the robot's arm (its logs name the problem)"

FAILURES = by_code(
    NamedFailure(
        "NOT_VISIBLE",
        "the referenced detection does not exist, names something else, or the object is "
        "not in view where the robot stands",
        True,
        (_LOOK_AGAIN, "navigate_to the place where the object is, then look for it"),
    ),
    NamedFailure(
        "DETECTION_STALE",
        "the detection is too old to trust: the object may have moved since",
        True,
        (_LOOK_AGAIN,),
    ),
    NamedFailure(
        "OUT_OF_REACH",
        "the object is out of the arm's reach from where the robot stands",
        False,
        ("ask a person to move the object within reach or to hand it over",),
    ),
    NamedFailure(
        "GRASP_FAILED",
        "the gripper closed on nothing or the object slipped",
        True,
        (
            "retry once: look again (find_object), then call pick with the new mask_ref",
            "if it fails again, ask a person to help",
        ),
    ),
    NamedFailure(
        "ALREADY_HOLDING",
        "the gripper is not empty",
        True,
        ("call place (or release) to put down what is held first, then pick",),
    ),
    NamedFailure(
        "NOTHING_HELD",
        "the gripper holds nothing to put down",
        False,
        ("call get_held to see what the robot holds",),
    ),
    NamedFailure(
        "NO_SURFACE",
        "there is no free surface in reach where the robot stands",
        True,
        ("navigate_to a place with free space, then call place again",),
    ),
    NamedFailure(
        "PLACE_FAILED",
        "the object did not come to rest where it was put",
        True,
        ("look (find_object) to see where it is, then ask a person if it fell",),
    ),
    NamedFailure(
        "ARM_NOT_READY",
        "the arm cannot move now (the base is moving, or an arm fault)",
        True,
        ("wait until the robot stands still, then call it again once", _OPERATOR),
    ),
    NamedFailure(
        "MANIPULATION_ERROR",
        "the robot's arm failed without naming a cause",
        True,
        ("call it again once; if it fails again, ask an operator",),
    ),
)

CODES: dict[tuple[Action, int], str] = {
    ("pick", 1): "MANIPULATION_ERROR",  # UNKNOWN
    ("pick", 2): "NOT_VISIBLE",  # DETECTION_NOT_FOUND
    ("pick", 3): "DETECTION_STALE",
    ("pick", 4): "OUT_OF_REACH",
    ("pick", 5): "GRASP_FAILED",
    ("pick", 6): "ALREADY_HOLDING",
    ("pick", 7): "ARM_NOT_READY",
    ("place", 1): "MANIPULATION_ERROR",  # UNKNOWN
    ("place", 2): "NOTHING_HELD",
    ("place", 3): "NO_SURFACE",
    ("place", 4): "PLACE_FAILED",
    ("place", 7): "ARM_NOT_READY",
}


def named_failure(action: Action, error_code: int) -> NamedFailure:
    return FAILURES[CODES.get((action, error_code), "MANIPULATION_ERROR")]
