"""A motion step cancelled by a supervision lapse while the brain was alive (issue 39 item 1).

The brain's lease lapsed on a motion server (its renewals came too late: a starved host, a
slow network) while the brain kept running: the server cancelled the step's motion with
``CANCELLED`` and the reason ``robot_mcp_kit.supervision.LAPSE_REASONS["lapsed"]`` (or its
refusal code). Such a step is not the mission's failure: the dispatcher re-leases, waits for
the server's lock to open, re-issues the same call once within the same mission and says so
once. Never while the software stop is latched, nor after an operator's stop (the mission is
paused then, and its tasks were dropped), nor twice for one step.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from robot_mcp_kit.supervision import LAPSE_REASONS, NOT_SUPERVISED

RECOVER_WAIT_S = 10.0
"""How long a lapsed step waits for a fresh lease and an open lock before its failure goes to
the planner as it came (the lease thread renews every period; a lock that stays shut this long
is not a moment's lapse)."""


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


def _place(location: object) -> str:
    return f"the {str(location).replace('_', ' ')}"


def carrying_on(call: IssuedCall) -> str:
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
    return f"I lost my safety link for a moment and stopped; it's back, so I'm {doing}."
