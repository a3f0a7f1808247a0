"""What the servers answered, as the robot says it (issue 31): a tool error's reason, a
failure's suggestions, a server's name, a map id inside free text. Codes and tool names stay
in step details and logs; a sentence gets the words a person needs, or nothing.

The servers' own sentences are used when they are already plain words (``robot_words.leaks``
finds nothing in them); otherwise the known codes have sentences here, and anything else is
said generically rather than read out raw.
"""

from __future__ import annotations

import json
import re
from collections.abc import Callable, Iterable

from robot_voice_chat.robot_words import SERVICES, leaks, service_name

Names = Callable[[str], str]  # a map id → how a sentence says it ("Alice's desk")
# What a code means to a person; keys upper case (servers send both cases).
REASONS = {
    "SAFETY_STOP_LATCHED": (
        "a software stop is latched, and an operator must press Clear stop before I move"
    ),
    "HELD_BY_SAFETY_STOP": "a stop paused the mission",
    "NOT_SUPERVISED": "my supervision of the robot had lapsed, so it refused to move",
    "POLICY_DENIED": "the operator's policy does not allow it without a yes",
    "OUT_OF_BOUNDS": "that is outside what the operator allows",
    "UNKNOWN_LOCATION": "the map has no such place",
    "NAVIGATION_BUSY": "the robot is busy with another drive",
    "NAVIGATION_TIMEOUT": "the drive took too long",
    "NO_PATH": "I found no way there (it may be blocked, for example by a closed door)",
    "ROBOT_STUCK": "I could not get any further along my way (something may be in the way)",
    "OBSTACLE_AHEAD": "something was too close to me to move",
    "GOAL_BLOCKED": "the spot I was going to is blocked",
    "START_BLOCKED": "I am boxed in where I stand",
    "PLANNER_FAILED": "my navigation could not work out a way there",
    "CONTROLLER_FAILED": "my navigation failed while following the way",
    "RECOVERY_FAILED": "my navigation could not free itself",
    "NAVIGATION_ABORTED": "my navigation gave up without saying why",
    "LOCALIZATION_LOST": "I do not know where I am on the map",
    "GOAL_OUTSIDE_MAP": "that spot is outside my map",
    "NAV2_CONFIG_ERROR": "my navigation is not set up right; an engineer must look at it",
    "NAV2_ERROR": "my navigation gave up with a problem I cannot name",
    "BASE_UNAVAILABLE": "my base stopped answering",
    "SERVER_RESTARTED": "it restarted and lost track of the task",
    "SERVICE_UNAVAILABLE": "my camera system is not answering",
    "SERVICE_TIMEOUT": "my camera system did not answer in time",
    "BRIDGE_CLOSED": "my camera system is not answering",
    "ARM_UNAVAILABLE": "my arm is not answering",
    "TIMEOUT": "it took too long",
    "CANCELLED": "it was cancelled",
    "UNKNOWN_TASK": "it no longer knows that task",
    "UNKNOWN_TEMPLATE": "it has no such camera skill",
}
_NOT_CONNECTED = re.compile(r"server '?(?P<server>[\w-]+)'? is not connected")
_TIMED_OUT = re.compile(r"timed out after")
_SERVER_TOOL = re.compile(r"\b(?P<server>[a-z_]+)\.[a-z_]+\b")
# navigate_to("corridor_b") inside a suggestion; "call navigate_to(...) again"
_NAV_CALL = re.compile(r"""navigate_to\(\s*["']?(?P<place>[\w\- ]+?)["']?\s*\)""")
_CALL_NAV = re.compile(r"""\bcall navigate_to\(\s*["']?(?P<place>[\w\- ]+?)["']?\s*\)""")
_AGAIN = re.compile(r"""call navigate_to\(\s*["']?(?P<place>[\w\- ]+?)["']?\s*\) again""")
# the guard's refusal after an approval was not given: "<tool> was not sent: denied (<why>)"
_NOT_APPROVED = re.compile(r"was not sent: (?:denied \((?P<why>.*)\)|(?P<other>.*))$")
_DENIED_BY = re.compile(r"^(?:denied|answered) (?:by (?P<who>[\w.@-]+)|'(?P<said>[^']*)')$")


def _parts(content: str) -> tuple[str, str]:
    """(code, sentence) of a tool error: the servers' ``{"error", "detail"}`` JSON, a task
    failure's ``{"error_code", "message"}``, or the backend's ``error: ...`` text."""
    try:
        data = json.loads(content)
    except ValueError:
        data = None
    if isinstance(data, dict):
        code = str(data.get("error") or data.get("error_code") or "")
        detail = str(data.get("detail") or data.get("message") or "")
        return code, detail
    return "", content.strip().removeprefix("error:").strip()


# codes whose servers' sentences are an engineer's ("its navigation stack sent nothing for 3 s")
_CODE_FIRST = frozenset({"BASE_UNAVAILABLE"})
# "(Nav2 error 208: no valid path: …)": the server's own code and words, for its log, not a person
_ENGINEERS = re.compile(r"\s*\([^()]*\berror(?: code)? \d{2,}[^()]*\)", re.IGNORECASE)


def reason_of(content: str, names: Names | None = None, known: Iterable[str] = ()) -> str:
    """Why a call failed, in plain words (no code, tool name or raw text)."""
    code, detail = _parts(content)
    not_approved = _NOT_APPROVED.search(detail) if code.upper() == "POLICY_DENIED" else None
    if not_approved is not None:
        return _why_not_approved(not_approved["why"] or not_approved["other"] or "")
    lost = _NOT_CONNECTED.search(detail)
    if lost is not None:
        return f"my {service_name(lost['server'])} is not connected"
    if code.upper() in _CODE_FIRST:
        return REASONS[code.upper()]
    said = plain_text(_ENGINEERS.sub("", detail), names, known) if detail else ""
    if said and not leaks(said):
        return said.rstrip(".")
    first = detail.split(" ", 1)[0]
    if code.upper() == "SERVER_RESTARTED" and first in SERVICES:
        return f"my {service_name(first)} restarted and lost track of the task"
    if code.upper() in REASONS:
        return REASONS[code.upper()]
    if _TIMED_OUT.search(detail):
        return REASONS["TIMEOUT"]
    server = _SERVER_TOOL.search(detail)
    if server is not None and server["server"] in SERVICES:
        return f"my {service_name(server['server'])} could not do it"
    return "something went wrong there"


# The part of the robot that does not answer, named as a person would (issue 39 item 5): the
# ROS side's codes (the vision node behind skill_control and perception, the arm, the base),
# and a server the brain lost (the perception buffer, the camera's controls, ...).
_DOWN_CODES = {
    "SERVICE_UNAVAILABLE": "My camera system",
    "SERVICE_TIMEOUT": "My camera system",
    "BRIDGE_CLOSED": "My camera system",
    "ARM_UNAVAILABLE": "My arm",
    "BASE_UNAVAILABLE": "The robot's base",
}
_DOWN_SERVERS = {
    "perception": "The part of me that collects what my camera sees",
    "skill_control": "The part of me that runs my camera",
    "manipulation": "My arm",
    "navigation": "My navigation",
    "episodic": "My memory of what happened",
    "memory": "My memory of how to do things",
}


def part_down(content: str) -> str | None:
    """The part of the robot a failed call says is not answering ("My camera system"), or
    None when the failure is of another kind (a refusal, nothing found, ...)."""
    code, detail = _parts(content)
    lost = _NOT_CONNECTED.search(detail)
    if lost is not None:
        return server_part(lost["server"])
    if code.upper() in _DOWN_CODES:
        return _DOWN_CODES[code.upper()]
    server = _SERVER_TOOL.search(detail) if _TIMED_OUT.search(detail) else None
    if server is not None and server["server"] in _DOWN_SERVERS:
        return _DOWN_SERVERS[server["server"]]
    return None


def server_part(server: str) -> str:
    """A server the brain lost as the part of the robot it is ("My arm")."""
    return _DOWN_SERVERS.get(server, f"My {service_name(server)}")


def down_sentence(part: str, doing: str) -> str:
    """``My camera system isn't answering, so I can't look right now.``"""
    return f"{part} isn't answering, so I can't {doing} right now."


def _why_not_approved(why: str) -> str:
    """An operator's no, an approval nobody gave in time, a stop that withdrew the question,
    or one nobody could ask for — each said as what happened (a "no" is not the policy's)."""
    if why.startswith("no answer within"):
        return f"nobody approved it in time ({why})"
    if why.startswith("safety stop"):
        return "a stop withdrew the request for approval"
    if why.startswith("the call was abandoned"):
        return "the mission ended before anyone approved it"
    if why.startswith("it needs an operator's approval"):
        return why
    denied = _DENIED_BY.match(why)
    who = denied["who"] if denied is not None else None
    if who and who != "operator":
        return f"the operator ({who}) said no"
    if denied is not None or not why or leaks(why):
        return "the operator said no"
    return f"the operator said no: {why}"


def by_id(place: str) -> str:
    """Without the live place list: the map id with spaces ("the corridor b")."""
    return f"the {place.replace('_', ' ')}"


def plain_text(text: str, names: Names | None = None, known: Iterable[str] = ()) -> str:
    """``text`` with the snake_case map ids in ``known`` said by their names ("via
    corridor_b" → "via the corridor B")."""
    say = names or by_id
    for place in sorted((k for k in known if "_" in k), key=len, reverse=True):
        spoken = say(place).replace("\\", "\\\\")  # a literal replacement
        text = re.sub(rf"(?:\bthe\s+)?\b{re.escape(place)}\b", spoken, text)
    return text


def suggestion_of(text: str, names: Names | None = None, known: Iterable[str] = ()) -> str | None:
    """A server's suggestion as something the robot can say, or None when it is only for a
    planner (``retry``, ``retry_after_s:300``) or cannot be said plainly."""
    say = names or by_id
    said = _AGAIN.sub(lambda m: f"send me to {say(m['place'])} again", text)
    # "call navigate_to("x") to resume the drive": the call is the planner's, the drive mine
    said = _CALL_NAV.sub(lambda m: f"drive to {say(m['place'])}", said)
    said = _NAV_CALL.sub(lambda m: f"a drive to {say(m['place'])}", said)
    said = re.sub(r"\s*\([^()]*\)", "", said)  # the calls a planner would make
    said = plain_text(said.strip().rstrip("."), say, known)
    if not said or said.lower().startswith("retry") or leaks(said):
        return None
    return said
