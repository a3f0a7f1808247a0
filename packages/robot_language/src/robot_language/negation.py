"""Negations and corrections (issue 32): what the person said *not* to do is taken out of the
request and remembered, so that place is never driven to, proposed or offered as a choice.

- corrections: "go to the kitchen no wait the mailroom", "drive to reception, actually make
  that Bob's desk", "go to the kitchen, sorry, I mean the mailroom": the part after the marker
  replaces the place of the last leg (or the whole leg when it has a verb of its own);
- negations: "don't go to the kitchen, go to reception instead", "not the kitchen, the
  mailroom", "go to the meeting room not the kitchen", "X instead of / rather than Y";
- "skip the kitchen and go straight to reception", "avoid the mailroom", "stay away from X";
- "don't go to the kitchen" alone leaves nothing to do (``only_negative``).
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass, field

from robot_language import clauses as cl
from robot_language.config_file import patterns, word_lists

_P = patterns("negation", "leading", "not_first", "instead_of_first", "not_alone", "instead_of",
              "not_last", "question", "still_negated", "instead", "place_tail", "obj_verb",
              "first_prep")  # fmt: skip

_VERB = (
    r"(?:go|drive|head|come|move|walk|travel|return|navigate|visit|find|look|search|locate|"
    r"check|bring|fetch|get|take|grab|carry|deliver|watch|patrol|swing|pop)"
)
_DONT = re.compile(
    r"^(?:please |you |there's |there is )?(?:don't|do not|never|no need to|needn't|need not|"
    r"shouldn't|mustn't|must not|skip(?! to\b)|avoid|stay away from|stay out of|keep away from|"
    r"keep out of)\s+(?:(?:have|need|got) to\s+|bother (?:to\s+)?)?(?P<neg>.+?)"
    rf"(?:,\s*|\s+(?:but|instead|rather)\s+|(?:\s+(?:and|then|but))?\s+(?={_VERB}\b)|$)"
    r"(?P<rest>.*)$"
)
_WORDS = word_lists("words", "marks", "pairs", "strong", "not_after_no", "no_after")


@dataclass(frozen=True)
class Said:
    """The request with its corrections made and its negations taken out."""

    text: str
    negated: list[str] = field(default_factory=list)  # phrases the person said not to use
    refused: str = ""  # the negated leg as said ("go to the kitchen"), when only that was said

    @property
    def only_negative(self) -> bool:
        return not self.text and bool(self.refused)


def read(text: str, is_place: Callable[[str], bool]) -> Said:
    """``text`` (normalised) → what to do and what not to; ``is_place``: whether a phrase
    names a place on the live map (a correction that is a place replaces a place)."""
    text = _P["leading"].sub("", text).strip(" ,")
    negated: list[str] = []
    text = _correct(text, is_place, negated)
    for pattern in (_DONT, *(_P[n] for n in ("not_first", "instead_of_first", "not_alone"))):
        match = pattern.match(text)
        if match is not None:
            leg = _trim(match["neg"])
            negated.append(_place_of(leg))
            rest = _trim(_P["instead"].sub("", match["rest"]))
            if not rest:
                return Said("", negated, leg)
            text = rest
            break
    for pattern in (_P["instead_of"], _P["not_last"]):
        match = pattern.match(text)
        if match is not None and not _P["question"].match(match["rest"]):
            negated.append(_place_of(_trim(match["neg"])))
            text = _trim(match["rest"])
            break
    return Said(_trim(_P["instead"].sub("", text)), [n for n in negated if n])


def _correct(text: str, is_place: Callable[[str], bool], negated: list[str]) -> str:
    """The last correction in ``text`` made: "A <marker> B" → A with B in place."""
    found = _last_mark(text)
    if found is None:
        return text
    before, after = found
    after = _trim(_P["instead"].sub("", after))
    legs = cl.clauses(before)
    if not legs or not after:
        return text
    *kept, last = legs
    if is_place(after) and not re.match(rf"^{_VERB}\b", after):
        if is_place(last) and not _P["place_tail"].match(last):
            negated.append(cl.strip_article(last))
            last = after
        elif (tail := _P["place_tail"].match(last)) is not None:
            negated.append(cl.strip_article(tail["place"]))
            last = tail["head"] + after
        else:
            negated.append(_place_of(last))
            last = after
    elif re.match(rf"^{_VERB}\b", after):
        negated.append(_place_of(last))
        last = after
    elif (verb := _P["obj_verb"].match(last)) is not None and not _P["place_tail"].match(last):
        last = verb["verb"] + after  # "find the mug, no wait, the scissors"
    else:
        return text
    return ", then ".join([*kept, last])


def _last_mark(text: str) -> tuple[str, str] | None:
    """(before, after) around the last run of correction words that is not at the start."""
    tokens = re.findall(r"[\w']+|,", text)
    best: tuple[int, int] | None = None
    i = 1
    while i < len(tokens):
        j, strong = i, False
        while j < len(tokens):
            pair = " ".join(tokens[j : j + 2])
            if pair in _WORDS["pairs"]:
                strong, j = strong or pair in _WORDS["strong"], j + 2
            elif tokens[j] == "," or (tokens[j] in _WORDS["marks"] and _marks(tokens, j)):
                strong = strong or tokens[j] in _WORDS["strong"]
                j += 1
            else:
                break
        if j > i and strong and j < len(tokens) and any(t != "," for t in tokens[i:j]):
            best = (i, j)
            i = j
        else:
            i += 1
    if best is None:
        return None
    before = _join(tokens[: best[0]])
    after = _join(tokens[best[1] :])
    return (before, after) if before and after else None


def _marks(tokens: list[str], j: int) -> bool:
    """Whether ``tokens[j]`` is a correction word here (not "no one", "wait for", "there's no
    parcel")."""
    word = tokens[j]
    after = tokens[j + 1] if j + 1 < len(tokens) else ""
    before = tokens[j - 1] if j > 0 else ""
    if word == "wait":
        return after in (",", "no") or before in ("no", ",")
    if word == "no":
        return after not in _WORDS["not_after_no"] and before not in _WORDS["no_after"]
    if word in ("oh", "uh", "well"):
        return after in _WORDS["marks"] or after in ("i", ",")
    return True


def _join(tokens: list[str]) -> str:
    return re.sub(r"\s+,", ",", " ".join(tokens)).strip(" ,")


def _trim(text: str) -> str:
    text = text.strip(" ,.!?")
    return re.sub(r"\s+(?:and|then|but|please)$", "", text).strip(" ,")


def _place_of(leg: str) -> str:
    """The place phrase of a negated leg ("go to the kitchen" → "the kitchen"; a bare place is
    itself)."""
    match = _P["first_prep"].match(leg)
    return cl.strip_article(match["place"]) if match is not None else cl.strip_article(leg)


def still_negated(text: str) -> bool:
    """A negation this module could not take apart is left in ``text``: nothing in it may be
    acted on or proposed (it might be the very place the person ruled out)."""
    return _P["still_negated"].search(text) is not None
