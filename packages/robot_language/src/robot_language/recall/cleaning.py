"""A question about the past made plain before it is read: chatty openers dropped, texting
shorthand spelled out, other verbs of seeing read as see / saw / seen, the robot named in the
third person read as "you", clock words as digits; and a typo in the question word or the verb
read past (rapidfuzz, MIT)."""

from __future__ import annotations

import re

from rapidfuzz import fuzz, process

from robot_language.normalise import normalise
from robot_language.recall.phrasings import PHRASINGS
from robot_language.recall.times import SPOKEN_CLOCK, clock_digits

TYPO_CUTOFF = 85.0  # one letter dropped, added or swapped in a short word ("wher", "wat")
_OPENER = re.compile(
    r"^(?:(?:yo|hey|hi|hello|ok|okay|so|well|um+|uh+|erm|oh|alright|robot)\b[\s,;:!.-]*)+"
    r"(?=\S)"
)
_ROBOT = r"(?:the robot|the bot|this robot|our robot|your robot|robot|it)"
_ADVERB = r"(?:last|first|ever|just|already|recently|actually|most recently)"
# Other verbs of seeing, said after their subject ("did you catch sight of", "have you come
# across", "when did it last lay eyes on"), read as see / saw / seen: the auxiliary before the
# verb picks the form ("have you come across" → "have you seen", "did you run into" → "did you
# see"). Only after a subject, so "run into the kitchen" stays a request's words.
_SEEING = re.compile(
    rf"\b(?P<subject>you|{_ROBOT})\s+(?P<adverb>{_ADVERB}\s+)?(?:"
    + "|".join(
        f"(?P<{form}>{'|'.join(map(re.escape, verbs))})"
        for form, verbs in PHRASINGS.seeing_forms.model_dump().items()
    )
    + r")\b"
)
_HAVE = re.compile(r"\b(?:have|has|had|'ve)\b")
_DO = re.compile(r"\b(?:did|do|does)\b")
# the robot named in the third person as the one who saw ("what did the robot see", "did it
# spot the mug"): the same question as "you"; never "was it seen" (there "it" is the thing)
_ROBOT_SUBJECT = re.compile(
    rf"\b(?P<aux>did|does|has|have|had) {_ROBOT}(?=\s+(?:(?:last|first|ever|just|already|"
    r"recently|most recently)\s+)?(?:see|seen|spot|spotted|notice|noticed|observe|observed|"
    r"detect|detected|pick up|picked up)\b)"
)
_SECOND_PERSON = {"has": "have", "does": "do"}


def clean(text: str) -> str:
    """Lower case, chatty openers dropped ("yo, ...", "hey robot, ...", "ok so ..."), texting
    shorthand spelled out ("u seen" → "you seen"), clock words as digits ("half past two" →
    "2:30")."""
    plain = _OPENER.sub("", normalise(text, spoken=False).strip(" .!?"))
    plain = " ".join(PHRASINGS.shorthand.get(w, w) for w in plain.split())
    plain = _ROBOT_SUBJECT.sub(_as_you, _SEEING.sub(_plain_seeing, plain))
    return SPOKEN_CLOCK.sub(clock_digits, plain)


def typos_fixed(clean: str) -> str:
    """``clean`` with a typo in its opening word or in the verb after "you" corrected."""
    words = clean.split()
    for i, word in enumerate(words):
        if i == 0:
            words[i] = PHRASINGS.run_together.get(word) or closest(word, PHRASINGS.opening_words)
        elif words[i - 1] == "you":
            words[i] = closest(word, PHRASINGS.verbs)
    return " ".join(words)


def closest(word: str, vocabulary: list[str]) -> str:
    """``word``, or the one vocabulary word at least :data:`TYPO_CUTOFF` alike (ties: none)."""
    if word in vocabulary or len(word) < 3 or not word.isalpha():
        return word
    found = process.extract(word, vocabulary, scorer=fuzz.ratio, score_cutoff=TYPO_CUTOFF, limit=2)
    if not found or (len(found) == 2 and found[1][1] == found[0][1]):
        return word
    return str(found[0][0])


def _as_you(match: re.Match[str]) -> str:
    return f"{_SECOND_PERSON.get(match['aux'], match['aux'])} you"


def _plain_seeing(match: re.Match[str]) -> str:
    before = match.string[: match.start()]
    have = max((m.start() for m in _HAVE.finditer(before)), default=-1)
    do = max((m.start() for m in _DO.finditer(before)), default=-1)
    if have > do:
        verb = "seen"
    elif do > have or match["base"] or match["both"]:
        verb = "see"
    else:
        verb = "saw"
    return f"{match['subject']} {match['adverb'] or ''}{verb}"
