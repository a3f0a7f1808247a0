"""NORMALISE, the first stage: speech-style input written the way the grammar reads it (issue
32): what a speech-to-text engine or a hurried thumb leaves in a request, taken out before
anything else reads it. The one ``normalise`` of the package.

- casing, curly apostrophes, and one word per sentence ("Go. To. The. Meeting. Room.");
- hesitations and fillers ("uh", "um", "like" as a filler), stutters ("go go to the the kitchen");
- texting spellings ("u", "2", "pls", "thx") and contractions typed without their apostrophe
  ("dont", "whats", "theres");
- possessives without their apostrophe, against the live places ("bobs desk" → "bob's desk"
  when a place is Bob's);
- spoken numbers as digits ("room twenty three" → "room 23"), by ``text2num`` (MIT); small isolated
  numbers and ordinals ("two", "first", "a second") are left as words.

The word lists are data: ``config/normalise.yaml``.
"""

from __future__ import annotations

import re
from collections.abc import Iterable

from text_to_num import alpha2digit  # type: ignore[import-untyped]

from robot_language.config_file import CONFIG, Strict, read_model


class _Words(Strict):
    """``config/normalise.yaml``: the words this stage reads."""

    hesitations: frozenset[str]
    texting: dict[str, str]
    contractions: dict[str, str]
    id_before: frozenset[str]
    to_after: frozenset[str]
    before_to: frozenset[str]
    for_after: frozenset[str]
    like_keeps: frozenset[str]


WORDS = read_model(CONFIG / "normalise.yaml", _Words, "normalise")
_LEADING = re.compile(r"^(?:(?:so|well|alright|all right|oh|yo|okay so|ok so|right,)[\s,]+)+")
_YOU_KNOW = re.compile(r"(?:^|,)\s*you know\s*(?:,|$)")
_SENTENCES = re.compile(r"[.!?]+")
_WORD = re.compile(r"[\w']+")
ONES = "one|two|three|four|five|six|seven|eight|nine"
TEENS = "ten|eleven|twelve|thirteen|fourteen|fifteen|sixteen|seventeen|eighteen|nineteen"
TENS = "twenty|thirty|forty|fifty|sixty|seventy|eighty|ninety"
_NUMBER_WORDS = re.compile(rf"\b(?:{ONES}|{TEENS}|{TENS}|hundred|thousand)\b")


def possessors(names: Iterable[str]) -> set[str]:
    """The people whose places the map has ("Alice's desk" → alice), from place texts."""
    return {m.lower() for text in names for m in re.findall(r"\b(\w+)['’]s\b", text)}


def normalise(text: str, owners: Iterable[str] = (), *, spoken: bool = True) -> str:
    """``text`` as the grammar reads it; ``owners``: names whose possessive a place uses
    ("bob" for "Bob's desk"), so "bobs desk" gets its apostrophe back. ``spoken=False`` stops
    after case, apostrophes and spaces: for text that is no person's words (an instruction the
    planner wrote, an intent's example) or was normalised already."""
    text = " ".join(text.replace("’", "'").replace("‘", "'").lower().split())
    if not spoken:
        return text
    text = _one_word_sentences(text)
    text = _words(text, {f"{o}s": f"{o}'s" for o in owners})
    text = re.sub(r"\b(\w+ \w+) \1\b", r"\1", text)  # a restart: "go to go to the kitchen"
    text = _YOU_KNOW.sub(",", text).strip(" ,")
    text = _LEADING.sub("", text)
    if _NUMBER_WORDS.search(text):
        text = alpha2digit(text, "en")
    return " ".join(text.split())


def _one_word_sentences(text: str) -> str:
    """ "go. to. the. meeting. room." → "go to the meeting room": three or more sentences of
    one or two words each are one sentence said slowly."""
    pieces = [p.strip() for p in _SENTENCES.split(text) if p.strip()]
    if len(pieces) >= 3 and all(len(p.split()) <= 2 for p in pieces):
        return " ".join(pieces)
    return text


def _word(heard: str, before: str, after: str, owned: dict[str, str]) -> str:
    if heard in WORDS.hesitations:
        return ""
    if heard == "like" and before not in WORDS.like_keeps:
        return ""
    if heard == "2" and (before in WORDS.to_after or after in WORDS.before_to):
        return "to"
    if heard == "4" and (before in WORDS.for_after or after in WORDS.before_to):
        return "for"
    if heard == "r" and (before in {"where", "what", "how", "who", "why", "when", "you"}
                         or after in {"you", "u"}):  # fmt: skip
        return "are"
    if heard == "id" and after in WORDS.id_before:
        return "i'd"
    if heard in owned:
        return owned[heard]
    return WORDS.texting.get(heard) or WORDS.contractions.get(heard) or heard


def _words(text: str, owned: dict[str, str]) -> str:
    """Each word as the grammar reads it, looking at its neighbours; punctuation, clock times
    ("15:30") and everything between the words are kept as they were."""
    found = list(_WORD.finditer(text))
    out: list[str] = []
    kept = ""  # the last word written
    end = 0
    for i, match in enumerate(found):
        after = found[i + 1][0] if i + 1 < len(found) else ""
        word = _word(match[0], kept, after, owned)
        gap = text[end : match.start()]
        end = match.end()
        if not word or (word == kept and word.isalpha() and not gap.strip()):  # "the the"
            out.append(gap if gap.strip() else "")
            continue
        out += [gap, word]
        kept = word
    out.append(text[end:])
    joined = "".join(out)
    joined = re.sub(r"\s+([,.!?;:])(?!\d)", r"\1", joined)
    return re.sub(r"([,;])(?:\s*[,;])+", r"\1", " ".join(joined.split()))
