"""Short, true sentences from the episodic memory's structured answers (what_happened,
last_seen, pose_at): labels, places and the server's own "N s ago" and ISO times, never a time
the brain computed, and "I have no record of ..." when nothing was recorded (never a guess)."""

from __future__ import annotations

import json
from collections.abc import Callable
from typing import Any

from robot_language.places import PlaceIndex, located
from robot_language.recall import (
    LAST_SEEN,
    POSE_AT,
    WHAT_HAPPENED,
    Recall,
)
from robot_voice_chat.services.llm.rules.plain import reason_of

NOT_CONNECTED = (
    "I can't answer questions about the past right now: my episodic memory (the episodic "
    "server) is not connected."
)
_MAX_LISTED = 8
Names = Callable[[str], str]  # a map id → how a sentence says it ("Alice's desk")


def by_id(name: str) -> str:
    """Without the live place list: the map id with spaces ("the desk alice")."""
    return f"the {name.replace('_', ' ')}"


def names_of(places: PlaceIndex | None) -> Names:
    """How sentences say places: the live place list's human names, else the ids."""
    return places.spoken if places is not None and places.places else by_id


def recollection(
    recall: Recall | None,
    tool: str,
    content: str,
    is_error: bool,
    names: Names = by_id,
    asked: str = "",
) -> str:
    """The answer to ``recall`` (None: a call whose question we no longer hold) from what
    ``tool`` returned; ``names`` says the places (the live place list's human names);
    ``asked``: the question itself, which the memory may already hold as the newest line."""
    if is_error:
        return f"I couldn't look that up in my memory: {_error_detail(content)}"
    data = _json(content)
    if not isinstance(data, dict):
        return "I couldn't look that up in my memory: the episodic server gave no answer."
    if tool == LAST_SEEN:
        return last_seen_sentence(data, recall, names)
    if tool == POSE_AT:
        return pose_sentence(data, recall, names)
    if tool == WHAT_HAPPENED:
        return digest_sentence(data, recall, names, asked)
    return str(data.get("answer") or data.get("summary") or "Done.")


# --- last_seen ------------------------------------------------------------------------------
def last_seen_sentence(data: dict[str, Any], recall: Recall | None, names: Names = by_id) -> str:
    results = [r for r in data.get("results") or [] if isinstance(r, dict)]
    asked = (recall.obj if recall else None) or str(data.get("query") or "that")
    where = data.get("place") or (recall.place if recall else None)
    if not data.get("found") or not results:
        at = _at(where, names)
        return f"I have no record of seeing {_the(asked)}{at}."
    if recall is not None and recall.first:
        more = len(results) >= int(recall.arguments["n"])
        return _first_seen_sentence(results, asked, more, names)
    top = results[0]
    last = top.get("last_seen") or {}
    label = str(top.get("label") or asked)
    # the server corrected a typo against the labels it holds: said, so the person can tell
    read_as = f" (I read '{data['query']}' as {label})" if data.get("read_as") else ""
    sentence = (
        f"I last saw {_the(label)}{read_as}{_at(top.get('place'), names)} "
        f"{last.get('ago', '')} ({_clock(last)})"
    )
    if top.get("seen_for") and not _glimpse(top):
        sentence += f", for {top['seen_for']}"
    sentence += "."
    absent = top.get("absent_since")
    if isinstance(absent, dict):
        sentence += f" When I looked there again {absent.get('ago', '')} it was gone."
    # "where is it now?" asks for the present: the last place only, never older ones
    asks_now = recall is not None and recall.offer
    earlier = next(
        (r for r in results[1:] if r.get("place") and r.get("place") != top.get("place")), None
    )
    if asks_now:
        earlier = None
    if earlier is not None:
        seen = earlier.get("last_seen") or {}
        sentence += (
            f" Before that I saw it{_at(earlier.get('place'), names)} {seen.get('ago', '')}."
        )
    return sentence


def _first_seen_sentence(
    results: list[dict[str, Any]], asked: str, more: bool, names: Names
) -> str:
    """The earliest sighting on record (results come newest first)."""
    oldest = results[-1]
    first = oldest.get("first_seen") or {}
    label = _the(str(oldest.get("label") or asked))
    sentence = (
        f"The first time I have on record, I saw {label}{_at(oldest.get('place'), names)} "
        f"{first.get('ago', '')} ({_clock(first)})"
    )
    if more:
        sentence += f" (the earliest of the last {len(results)} times I saw it)"
    if len(results) > 1:
        last = results[0].get("last_seen") or {}
        sentence += f"; I last saw it{_at(results[0].get('place'), names)} {last.get('ago', '')}"
    return sentence + "."


# --- pose_at --------------------------------------------------------------------------------
def pose_sentence(data: dict[str, Any], recall: Recall | None, names: Names = by_id) -> str:
    when = recall.said if recall and recall.said else "then"
    clock = _clock(data)
    if not data.get("found"):
        return f"I have no record of where I was {when} ({clock})."
    place = data.get("place")
    pose = data.get("pose") or {}
    if place:
        where = located(names(str(place)))
    elif isinstance(pose.get("x"), int | float) and isinstance(pose.get("y"), int | float):
        where = f"between places, at x={pose['x']:.1f} m, y={pose['y']:.1f} m"
    else:
        where = "somewhere I can't name"
    sentence = f"{_capital(when)} ({clock}) I was {where}"
    mission = data.get("mission")
    if isinstance(mission, dict) and mission.get("text"):
        sentence += f", on the mission “{mission['text']}”"
    return sentence + "."


# --- what_happened --------------------------------------------------------------------------
def digest_sentence(
    data: dict[str, Any], recall: Recall | None, names: Names = by_id, asked: str = ""
) -> str:
    items = _without_the_question(
        [i for i in data.get("items") or [] if isinstance(i, dict)], asked
    )
    when = none = _when(data, recall)
    if recall is not None and recall.around:  # "at 3 pm": the window the server used
        when = _between(data)
        none = f"{recall.said} ({when})"
    kind = recall.kind if recall else "digest"
    if kind == "seen":
        return seen_sentence(items, when, names, none)
    if not items:
        return f"I have no record of anything happening {none}."
    parts = []
    visited = _visits(items, names)
    if visited:
        parts.append(
            f"I was {located(visited[0])}"
            if len(visited) == 1
            else f"I went to {_listing(visited)}"
        )
    missions = _missions(items)
    if missions:
        parts.append(missions)
    seen = _sightings(items, names)
    if seen:
        parts.append(f"I saw {seen}")
    notes = [i for i in items if i.get("kind") in ("scene", "observation", "event")]
    if notes:
        parts.append("I noted: " + "; ".join(f"“{n.get('text', '')}”" for n in notes[-2:]))
    said = [i for i in items if i.get("kind") in ("user", "robot")]
    if said:
        parts.append(_conversation(said))
    if not parts:
        return f"I have no record of anything happening {none}."
    more = " (only the latest events)" if data.get("truncated") else ""
    digest = f"{_capital(when)}{more}: " + "; ".join(parts)
    return digest if digest.endswith((".”", "?”", "!”")) else f"{digest}."


def seen_sentence(
    items: list[dict[str, Any]], when: str, names: Names = by_id, none: str | None = None
) -> str:
    """``none``: how the time is said when nothing was seen (default ``when``)."""
    seen = _sightings(items, names, with_ago=True)
    if not seen:
        return f"I have no record of seeing anything {none or when}."
    return f"{_capital(when)} I saw {seen}."


def last_sightings_sentence(content: str, names: Names = by_id) -> str:
    """What the robot saw last (a what_happened answer of sightings), newest first: the
    historical mode of "what do you see"."""
    data = _json(content)
    items = [i for i in (data or {}).get("items") or [] if isinstance(i, dict)]
    sightings = [i for i in items if i.get("kind") == "sighting"]
    if not sightings:
        return "I have no record of seeing anything in the last day."
    newest = list(reversed(sightings))[:3]
    listed = [
        f"{_the(str(i.get('label')))}{_at(i.get('place'), names)} {i.get('ago', '')} ({_clock(i)})"
        for i in newest
    ]
    return f"The last I saw: {_listing(listed)}."


def _when(data: dict[str, Any], recall: Recall | None) -> str:
    start = data.get("start") or {}
    if recall is None:
        return f"since {start.get('ago', 'then')}"
    if recall.since_turn:
        if recall.said == "while away":  # the previous turn was not known
            return "in the last hour (I don't know when you left)"
        return f"since you last spoke to me ({start.get('ago', '')})"
    return recall.said


def _between(data: dict[str, Any]) -> str:
    """``between 14:55 and 15:05 CET``: the window the server resolved, on the site's clock."""
    (start, start_zone), (end, end_zone) = _minutes(data.get("start")), _minutes(data.get("end"))
    if start_zone == end_zone:
        return f"between {start} and {end} {end_zone}".rstrip()
    return f"between {start} {start_zone} and {end} {end_zone}"  # the clocks changed


def _minutes(when: object) -> tuple[str, str]:
    """``(14:55, CET)``: a window is said to the minute."""
    clock, _, zone = _clock(when).partition(" ")
    return (clock[:5] if len(clock) == 8 and clock[2] == ":" else clock), zone


def _visits(items: list[dict[str, Any]], names: Names) -> list[str]:
    places: list[str] = []
    for item in items:
        if item.get("kind") == "visit" and item.get("place"):
            place = names(str(item["place"]))
            if not places or places[-1] != place:
                places.append(place)
    return places


def _missions(items: list[dict[str, Any]]) -> str:
    started = [i for i in items if i.get("kind") == "mission_started"]
    finished = [i for i in items if i.get("kind") == "mission_finished"]
    said = [f"started “{i.get('text', '')}” {i.get('ago', '')}" for i in started]
    said += [f"finished “{i.get('text', '')}”" for i in finished if not started]
    if started and finished:
        said.append(f"last finished: “{finished[-1].get('text', '')}”")
    return "missions: " + "; ".join(said) if said else ""


def _without_the_question(items: list[dict[str, Any]], asked: str) -> list[dict[str, Any]]:
    """The items less the newest line the person said if it is the question being answered
    (the brain records each turn as it arrives, so the digest can already hold it)."""
    question = asked.strip()
    for index in range(len(items) - 1, -1, -1):
        item = items[index]
        if item.get("kind") == "user":
            if question and str(item.get("text", "")).strip() == question:
                return items[:index] + items[index + 1 :]
            break
    return items


def _conversation(lines: list[dict[str, Any]]) -> str:
    """The last two lines said, quoted (who said them), and how many more there were."""
    quoted = [
        f"{'you' if line.get('kind') == 'user' else 'I'} said “{line.get('text', '')}”"
        for line in lines[-2:]
    ]
    more = len(lines) - len(quoted)
    lines_more = f"{more} more line{'s' if more != 1 else ''} of conversation"
    return "; ".join(quoted) + (f" (and {lines_more})" if more else "")


def _sightings(items: list[dict[str, Any]], names: Names, with_ago: bool = False) -> str:
    seen: dict[tuple[str, str], dict[str, Any]] = {}
    for item in items:
        if item.get("kind") == "sighting" and item.get("label"):
            seen.setdefault((str(item["label"]), str(item.get("place") or "")), item)
    listed = [
        f"{_the(label)}{_at(place, names)}"
        + (f" (first seen {item.get('ago', '')})" if with_ago else "")
        for (label, place), item in seen.items()
    ]
    if len(listed) > _MAX_LISTED:
        listed = [*listed[:_MAX_LISTED], f"{len(listed) - _MAX_LISTED} more"]
    return _listing(listed)


# --- words ----------------------------------------------------------------------------------
def _at(place: object, names: Names = by_id) -> str:
    """`` in the kitchen``, `` at Alice's desk``; "" without a place."""
    return f" {located(names(str(place)))}" if place else ""


def _the(thing: str) -> str:
    return thing if thing.split(" ", 1)[0] in ("the", "a", "an", "my") else f"the {thing}"


def _clock(when: object) -> str:
    """The wall clock of one of the server's time objects, as it gave it: its site-local
    ``"local": "2026-09-21 16:00:00 CET"`` → ``16:00:00 CET``, else its ISO ``"time"``
    ``2026-09-21T15:00:00.000Z`` → ``15:00:00 UTC``."""
    if not isinstance(when, dict):
        return "time unknown"
    local = str(when.get("local") or "")
    if len(local) > 11 and local[10] == " ":
        return local[11:]
    text = str(when.get("time") or "")
    if len(text) < 19 or text[10] != "T":
        return text or "time unknown"
    zone = " UTC" if text.endswith("Z") else ""
    return text[11:19] + zone


def _listing(parts: list[str]) -> str:
    if len(parts) <= 1:
        return "".join(parts)
    return ", ".join(parts[:-1]) + " and " + parts[-1]


def _capital(text: str) -> str:
    return text[:1].upper() + text[1:]


def _glimpse(result: dict[str, Any]) -> bool:
    """Seen for under a second: nothing worth a "for …" (never "for 0 s")."""
    seconds = result.get("seen_for_s")
    if isinstance(seconds, int | float):
        return seconds < 1
    return str(result.get("seen_for", "")).strip() in ("0 s", "less than a second")


def _json(content: str) -> Any:
    try:
        return json.loads(content)
    except ValueError:
        return None


def _error_detail(content: str) -> str:
    """The memory server's reason in plain words (its own sentence, or what its code means)."""
    return reason_of(content) if content.strip() else "my episodic memory could not answer"
