"""A motion step cancelled by a supervision lapse while the brain was alive (issue 39 item 1).

The brain's lease lapsed on a motion server (its renewals came too late: a starved host, a
slow network) while the brain kept running: the server cancelled the step's motion with
``CANCELLED`` and the reason ``robot_mcp_kit.supervision.LAPSE_REASONS["lapsed"]`` (or its
refusal code). Such a step is not the mission's failure: the dispatcher re-leases, waits for
the server's lock to open, re-issues the same call within the same mission and says so once.
Never while the software stop is latched, nor after an operator's stop (the mission is paused
then, and its tasks were dropped), nor more than ``MAX_RECOVERIES`` times for one step. A motion
call refused ``NOT_SUPERVISED`` when it was first sent (the lease lapsed a moment before; nothing
moved) is sent again the same way once the lock is open.

A drive that ended ``BASE_UNAVAILABLE`` (no NavigateToPose feedback for the navigation server's
``feedback_timeout_s``) is the same kind of moment when the base answers again right after: a
host starved of CPU for a few seconds starves robot-sim or Nav2 as much as the lease (seen in a
quiet CI run: both locks went silent for robot-sim, then no feedback for 3 s). It is re-issued
the same way once the base's pose is fresh again within ``BASE_BACK_WAIT_S``; a base that stays
silent (killed, powered off) fails the step as it came, that much later.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Any, Literal

from robot_mcp_kit.supervision import (
    LAPSE_REASONS,
    NOT_SUPERVISED,
    SAFETY_STOP_LATCHED,
    STOP_CLEARING,
)
from robot_mcp_kit.tool_errors import parse_tool_error
from robot_voice_chat.services.tools.base import ToolOutcome

RECOVER_WAIT_S = 10.0
"""How long a lapsed step waits for a fresh lease and an open lock before its failure goes to
the planner as it came (the lease thread renews every period; a lock that stays shut this long
is not a moment's lapse)."""


BASE_BACK_WAIT_S = 6.0
"""How long a drive that lost its base waits for a fresh pose before it fails as it came (a lost
base is reported to the person this much after the navigation server's own 3 s; the navigation
server's task says BASE_UNAVAILABLE at once either way). A fresh-clone CI run saw robot-sim
frozen 6.3 s with the host's other processes alive: 3 s of it before the loss, 3.3 s after."""

MAX_RECOVERIES = 3
"""How often one step is re-issued after a lost link before its failure goes to the planner. A
fresh-clone CI run saw robot-sim frozen twice within one drive (6 s, then 3 s, the host's other
processes alive): once was not enough, and a link that keeps failing is no moment's lapse."""

LostLink = Literal["lease", "base"]


@dataclass(frozen=True)
class IssuedCall:
    """A motion call as the dispatcher sent it: re-issued as it was after a lapse."""

    tool: str  # server.tool
    arguments: dict[str, Any]
    step_id: str | None


def is_lapse(payload: dict[str, Any]) -> bool:
    """A task failure that says supervision lapsed (not a latch, not the robot's own fault)."""
    if payload.get("error_code") not in ("CANCELLED", NOT_SUPERVISED):
        return False
    message = str(payload.get("message", ""))
    return LAPSE_REASONS["lapsed"] in message or NOT_SUPERVISED in message


def is_base_stall(payload: dict[str, Any]) -> bool:
    """A drive that ended because its base stopped answering for a moment (or for good)."""
    return payload.get("error_code") == "BASE_UNAVAILABLE" and payload.get("recoverable") is True


def lost_link(payload: dict[str, Any]) -> LostLink | None:
    """Which link a task failure says was lost for a moment, if one a step recovers from."""
    if is_lapse(payload):
        return "lease"
    return "base" if is_base_stall(payload) else None


def refused_unsupervised(outcome: ToolOutcome) -> bool:
    """A motion call refused for a moment, nothing moved: the lease lapsed again, or the
    server is still sweeping its goals after the stop was cleared. The text is read as a real
    server sends it (the MCP SDK's ``Error executing tool …:`` prefix) or bare."""
    error = parse_tool_error(outcome.text) if outcome.is_error else None
    if error is None:
        return False
    return error["error"] == NOT_SUPERVISED or (
        error["error"] == SAFETY_STOP_LATCHED and error["detail"].startswith(STOP_CLEARING)
    )


def base_answers(pose_result: str) -> bool:
    """``navigation.get_pose``'s answer shows a fresh pose from the base."""
    try:
        pose = json.loads(pose_result)
    except ValueError:
        return False
    return isinstance(pose, dict) and pose.get("stale") is False


def _place(location: object) -> str:
    return f"the {str(location).replace('_', ' ')}"


def carrying_on(call: IssuedCall, kind: LostLink = "lease") -> str:
    """What the robot says once, as it re-issues the step."""
    tool = call.tool.partition(".")[2]
    args = call.arguments
    if tool == "navigate_to" and isinstance(args.get("location"), str):
        doing = f"carrying on to {_place(args['location'])}"
    elif tool == "pick" and isinstance(args.get("label"), str):
        doing = f"carrying on with picking up the {args['label']}"
    elif tool == "place":
        doing = "carrying on with putting it down"
    elif tool == "release":
        doing = "carrying on with letting it go"
    else:
        doing = "carrying on"
    lost = "my safety link" if kind == "lease" else "contact with my base"
    return f"I lost {lost} for a moment and stopped; it's back, so I'm {doing}."
