"""Short follow-ups read against the question about the past before them ("and the laptop?",
"what about 2:24 pm?", "and an hour before that?", "where was that?"), and the questions about
the past the grammar could not read (answered with an honest "I did not understand")."""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import replace

from robot_language.recall.cleaning import clean, typos_fixed
from robot_language.recall.forms import last_seen, pose_at, window
from robot_language.recall.question import LAST_SEEN, POSE_AT, WHAT_HAPPENED, Recall
from robot_language.recall.slots import ARTICLE, place_of
from robot_language.recall.times import (
    NUMBER,
    UNIT,
    UNIT_S,
    ago,
    amount,
    clock,
    said_clock,
    seconds_of,
    span,
)

# "and before that?", "and an hour before that?", "what about 10 minutes earlier?"
_BEFORE_THAT = re.compile(
    r"^(?:(?:and|so|ok|okay|but|then)\s+)?(?:(?:what|how) about\s+)?"
    rf"(?:(?P<half>half an? (?:hour|minute))\s+|(?P<n>{NUMBER})\s*(?P<unit>{UNIT})\s+)?"
    r"(?:before (?:that|then)|earlier(?: than that| on)?|prior to that)$"
)
_AGAIN = re.compile(r"^(?:and |so )?(?:where|when) (?:was|is) (?:that|it|this)(?: again)?$")
_MORE = re.compile(r"^(?:and|also|ok and|okay and|(?:and )?(?:what|how) about)\s+(?P<rest>.+)$")
_PAST_QUESTION = re.compile(
    r"^(?:where|when|what|which|how|did|have|has|had|is|are|was|were|do|does|any|you|seen|last)"
    r"\b.*(?:\byou (?:saw|spotted|noticed|have seen|'ve seen|had seen|were|went)\b"
    r"|\b(?:did|have|had) you (?:see|seen|spot|spotted|notice|noticed|come across)\b"
    r"|\b(?:showed|turned|popped|ended|end|wound) up\b|\bago\b|\blast time\b|\bearlier\b"
    r"|\bstill\b)"
)
# a time in the server's grammar: relative (``-3600s``) or a clock time and its one offset
_TIME = re.compile(r"(?P<base>[^+-]+?)(?:\s*(?P<sign>[+-])\s*(?P<n>\d+)(?P<unit>[smh]))?")


def looks_like_recall(text: str) -> bool:
    """A question about the past the grammar could not read: it gets an honest "I did not
    understand" (never an action read from it). "and before that?" with nothing earlier to step
    back from is one too."""
    plain = typos_fixed(clean(text)) if text.strip() else ""
    return bool(_PAST_QUESTION.search(plain) or _BEFORE_THAT.match(plain))


def follow_up_recall(
    text: str, previous: Recall, is_place: Callable[[str], bool] | None = None
) -> Recall | None:
    """A short follow-up to a question about the past, read against it: "and the laptop?",
    "what about 2:24 pm?", "and in the mailroom?", "where was that?". ``is_place``: whether a
    phrase names one of the map's places ("the reception"): after a question about what was
    seen or happened, "what about the reception?" asks about that place, not a thing called
    "reception"."""
    plain = clean(text)
    if _AGAIN.match(plain):
        return previous
    before = _BEFORE_THAT.match(plain)
    if before is not None:
        return _before(previous, _amount_of(before))
    match = _MORE.match(plain)
    if match is None:
        return None
    rest = match["rest"]
    bare = ARTICLE.sub("", rest).strip()
    if is_place is not None and place_of(rest) is None and is_place(bare):
        if previous.tool == WHAT_HAPPENED:  # "what about the reception?": the same, there
            return replace(previous, arguments={**previous.arguments, "place": bare}, place=bare)
        if previous.tool == LAST_SEEN and previous.obj:
            return last_seen(f"when did you last see {previous.obj} in {bare}")
        return None  # "where were you at 3 pm" + "what about the kitchen?": not guessed
    if previous.kind == "pose_at" and (clock(rest) or ago(rest)):
        return pose_at(f"where were you {rest}")
    if previous.tool == WHAT_HAPPENED and (
        span(rest) or ago(rest) or place_of(rest) or clock(rest)
    ):
        return _another_window(rest, previous)
    if previous.kind not in ("last_seen", "seen") or place_of(rest) or clock(rest):
        return None
    if ago(rest) or span(rest):
        return None
    return last_seen(f"when did you last see {rest}")  # "and the laptop?": another thing


def _another_window(rest: str, previous: Recall) -> Recall | None:
    """ "what about 10 minutes ago / in the kitchen?": the same question, another time or place
    (a place alone keeps the earlier time)."""
    kinds = previous.arguments.get("kinds")
    said = {"seen": "what did you see", "visits": "where did you go"}.get(
        previous.kind, "what happened"
    )
    recall = window(f"{said} {rest}", kinds, previous.kind, default=None)
    if recall is not None and recall.place and not (span(rest) or ago(rest) or clock(rest)):
        kept = {k: v for k, v in previous.arguments.items() if k in ("start", "end")}
        return replace(recall, arguments={**recall.arguments, **kept}, said=previous.said)
    return recall


def _amount_of(match: re.Match[str]) -> int | None:
    """Seconds said in "(an hour) before that", None when no amount was said."""
    if match["half"]:
        return 1800 if "hour" in match["half"] else 30
    if match["n"]:
        return seconds_of(match["n"], match["unit"])
    return None


def _before(previous: Recall, back: int | None) -> Recall | None:
    """ "and before that?": the same question ``back`` seconds earlier; without an amount, one
    step of the earlier question's own length back (an hour ago → two hours ago, the last 30
    minutes → the 30 minutes before them). The server resolves the times (a clock time gets an
    offset: ``4:31pm -3600s``). None when the earlier question has no length to step back by
    (a clock time, "today", since your last turn, a sighting): the caller says it did not
    understand rather than guess."""
    if previous.tool == POSE_AT:
        time = str(previous.arguments.get("time", ""))
        step = back or _relative(time)
        shifted = _shift(time, step) if step else None
        if shifted is None:
            return None
        return replace(previous, arguments={"time": shifted}, said=_said_time(shifted))
    if previous.tool != WHAT_HAPPENED or previous.since_turn:
        return None
    start, end = str(previous.arguments.get("start", "")), previous.arguments.get("end")
    start_s = _relative(start)
    end_s = 0 if end is None and start_s else _relative(str(end)) if end else None
    if back is None and start_s is not None and end_s is not None:
        back = start_s - end_s
    if not back or (end is None and start_s is None):
        return None
    new_start, new_end = _shift(start, back), _shift(str(end or "-0s"), back)
    if new_start is None or new_end is None:
        return None
    arguments = {**previous.arguments, "start": new_start, "end": new_end}
    return replace(previous, arguments=arguments, said=f"{amount(back)} earlier", around=True)


def _relative(time: str) -> int | None:
    """Seconds before now of a relative time (``-3600s``), else None."""
    match = re.fullmatch(r"-(\d+)([smh])", time.strip())
    return int(match[1]) * UNIT_S[match[2]] if match else None


def _shift(time: str, back: int) -> str | None:
    """``time`` ``back`` seconds earlier, in the server's grammar: a relative time stays one
    (``-3600s`` → ``-7200s``), a clock time gets (or adds to) its one offset (``4:31pm`` →
    ``4:31pm -3600s``). None for any other time (ISO, "now")."""
    seconds = _relative(time)
    if seconds is not None:
        return f"-{seconds + back}s"
    match = _TIME.fullmatch(time.strip())
    if match is None or not re.fullmatch(r"\d{1,2}(?::\d{2})?(?:am|pm)?", match["base"].strip()):
        return None
    offset = int(match["n"] or 0) * UNIT_S[match["unit"] or "s"]
    offset = (-offset if match["sign"] == "-" else offset) - back
    base = match["base"].strip()
    return base if offset == 0 else f"{base} {'-' if offset < 0 else '+'}{abs(offset)}s"


def _said_time(time: str) -> str:
    """How an answer restates a shifted time: "2 hours ago", "an hour before 4:31 pm"."""
    seconds = _relative(time)
    if seconds is not None:
        return f"{amount(seconds)} ago"
    match = _TIME.fullmatch(time)
    if match is None or not match["n"]:
        return f"at {said_clock(time.strip())}"
    said = f"{amount(int(match['n']))} {'before' if match['sign'] == '-' else 'after'}"
    return f"{said} {said_clock(match['base'].strip())}"
