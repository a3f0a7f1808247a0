"""Questions about the past, read into the episodic tool call that answers them.

"what did you see 30 seconds ago", "when did you last see the mug", "where did you see the
scissors", "what happened while I was away / in the last 10 minutes", "where were you at
3 pm". The server resolves every time: the brain only passes relative strings (``-45s``) and
the clock text as said (``3pm``), never an absolute time it computed. A question about the past
never moves the robot.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from difflib import SequenceMatcher
from typing import Any, Literal

from robot_language.clauses import normalise

WHAT_HAPPENED = "episodic.what_happened"
LAST_SEEN = "episodic.last_seen"
POSE_AT = "episodic.pose_at"
_FIRST_OF = 20  # "when did you first see X": the earliest of its last this-many sightings
AROUND = "5m"  # "what did you see at 3 pm": the server's "3pm -5m" to "3pm +5m"
DEFAULT_AWAY = "-1h"  # "while I was away" when the previous turn is not known
RecallKind = Literal["seen", "digest", "away", "last_seen", "pose_at", "visits"]

_NUMBERS = {
    "a": 1, "an": 1, "one": 1, "two": 2, "three": 3, "four": 4, "five": 5, "six": 6,
    "seven": 7, "eight": 8, "nine": 9, "ten": 10, "eleven": 11, "twelve": 12, "fifteen": 15,
    "twenty": 20, "thirty": 30, "forty": 40, "forty five": 45, "fifty": 50, "sixty": 60,
    "ninety": 90, "a couple of": 2, "a couple": 2, "couple of": 2, "a few": 3, "few": 3,
}  # fmt: skip
_NUMBER = r"(?:\d+|" + "|".join(sorted(map(re.escape, _NUMBERS), key=len, reverse=True)) + ")"
_UNIT = r"(?:seconds?|secs?|s|minutes?|mins?|m|hours?|hrs?|h)"
_UNIT_S = {"s": 1, "m": 60, "h": 3600}
_AGO = re.compile(
    rf"\b(?:(?P<half>half an? (?:hour|minute))|(?P<n>{_NUMBER})\s*(?P<unit>{_UNIT}))\s+ago\b"
    r"|\b(?P<moment>just now|a moment ago|a second ago|a few seconds ago|a little while ago)\b"
)
_SPAN = re.compile(
    rf"\b(?:in|during|over|within|for|from)?\s*the\s+(?:last|past|previous)\s+"
    rf"(?:(?P<half>half an? hour|half hour)|(?P<quarter>quarter (?:of an )?hour)"
    rf"|(?:(?P<n>{_NUMBER})\s*)?(?P<unit>{_UNIT}))\b"
)
_CLOCK = re.compile(
    r"\b(?:at|around|about|by)?\s*(?P<clock>\d{1,2}(?::\d{2})?\s*(?:am|pm|a\.m\.|p\.m\.)"
    r"|\d{1,2}:\d{2}|noon|midday|midnight)(?![\w:])"
)
_TODAY = re.compile(r"\b(?:today|this morning|this afternoon|so far today)\b")
_RECENT = re.compile(r"\b(?:recently|lately|of late)\b")
_AWAY = re.compile(
    r"\b(?:while|when|whilst) i (?:was|were) (?:away|gone|out|out of the office|not here|"
    r"not around|at lunch|in a meeting|in the meeting)"
    r"|\bsince i (?:left|was (?:last )?here|went away|last (?:spoke|talked|asked|checked))"
    r"|\bsince (?:we|you and i) (?:last )?(?:spoke|talked)|\bsince my last (?:message|question)"
    r"|\bsince (?:the )?last time (?:we|i) (?:spoke|talked)|\bin my absence\b"
    r"|\bwhat did i miss\b|\bcatch me up\b|\bfill me in\b|\bbring me up to (?:date|speed)\b"
)
_SAW = r"(?:saw|spotted|noticed|have seen|'ve seen|had seen|came across|have come across)"
_SEE = r"(?:see|seen|spot|spotted|notice|noticed|come across|came across|run into)"
_LAST_SEEN = [
    # the thing moved on: "where did the scissors end up", "where has my mug got to"
    re.compile(
        r"\bwhere(?:'d| did| has| have| had) (?!(?:you|we|i|it|they|the robot)\b)(?P<obj>.+?) "
        r"(?:end(?:ed)? up|go|gone|went|get to|got to|gotten to|wind up|wound up|"
        r"disappear(?:ed)?(?: to)?|vanish(?:ed)?(?: to)?)$"
    ),
    # "the last time / place you saw X", "where's the last place you spotted X"
    re.compile(
        rf"\b(?:the )?(?:last|first) (?:time|place|spot) (?:that |where )?you {_SAW} (?P<obj>.+)"
    ),
    # the thing as subject: "when did the mug last show up", "when was the mug last seen"
    re.compile(
        r"\b(?:when|where) (?:did|was|were|has|have) (?:the last time )?(?P<obj>.+?) "
        r"(?:last |first )?(?:show(?:ed)? up|turn(?:ed)? up|appear(?:ed)?|pop(?:ped)? up)\b"
    ),
    re.compile(
        r"\b(?:the )?last time (?:that )?(?P<obj>.+?) (?:showed up|turned up|appeared|was seen)\b"
    ),
    re.compile(
        rf"\bhow (?:long|many \w+) ago (?:did|have) you (?:last |first )?{_SEE} (?P<obj>.+)"
    ),
    re.compile(
        r"\bhow long (?:did|have|were) you (?:see|seen|spot|watch|watched|looking at) (?P<obj>.+)"
    ),
    # "any idea where the charger is", "do you know where my keys went"
    re.compile(
        r"\b(?:any idea|do you know|have you any idea|got any idea|you know) where (?P<obj>.+?) "
        r"(?:is|are|was|were|went|ended up|might be|could be)\b"
    ),
    # the auxiliary dropped, as typed: "seen my keys?", "you seen the laptop anywhere"
    re.compile(r"^(?:you )?(?:seen|spotted|noticed|come across) (?P<obj>.+)"),
    re.compile(
        r"\b(?:when|where)\b(?: and (?:when|where))?(?: exactly)?\s+(?:did|have|had)\s+you\s+"
        r"(?:last|most recently|first|ever)?\s*(?:see|seen|spot|spotted|notice|noticed)\s+"
        r"(?P<obj>.+)"
    ),
    re.compile(
        r"\b(?:when|where)\b(?: and (?:when|where))?\s+you\s+(?:last\s+|most recently\s+)?"
        r"(?:saw|spotted|noticed|have seen|'ve seen)\s+(?P<obj>.+)"
    ),
    re.compile(
        r"\b(?:when was|what was) the last time (?:that )?you (?:saw|spotted|noticed|"
        r"have seen|'ve seen|had seen) (?P<obj>.+)"
    ),
    re.compile(r"\bhow long ago (?:did|have) you (?:last )?(?:see|seen|spot|spotted) (?P<obj>.+)"),
    re.compile(
        r"^(?:have|did|had) you (?:ever |already |recently )?(?:see|seen|spot|spotted|notice|"
        r"noticed|come across|came across|run into) (?P<obj>.+)"
    ),
    re.compile(
        r"\b(?:where|when) (?:was|were|is|are) (?P<obj>.+?) (?:last |first )?(?:seen|spotted)"
    ),
    re.compile(r"\bwhere (?:did|have) (?:i|we) (?:leave|left|put) (?P<obj>.+)"),
    re.compile(r"\b(?:any|seen any) (?:sign|trace) of (?P<obj>.+)"),
    re.compile(r"\bhave you (?:got any idea|any idea) where (?P<obj>.+?) (?:is|are|was|were)\b"),
]
# "where's the red mug now?", "where are the scissors": present tense, but the robot can only
# say where it last saw the thing; the answer offers to go and look (a question, never a motion)
_WHERE_NOW = re.compile(
    r"^where(?:'s| is| are|'re| r)\s+(?!(?:you|we|i|it|they|he|she|that|this|those|these|the robot|"
    r"everyone|everybody|everything|my location|your location)\b)(?P<obj>.+?)"
    r"(?:\s+(?:now|right now|at the moment|currently|then|kept|located|hiding|at))?$"
)
# "is my mug still in the kitchen": its sighting there, and whether it was gone later
_IS_STILL = re.compile(r"^(?:is|are) (?P<obj>.+?) still (?P<rest>(?:in|at|on|by|near) .+|there)$")
_SEEN = re.compile(
    r"\bwhat\s+(?:else\s+)?(?:did|have|had)\s+you\s+(?:just\s+)?(?:see|seen|spot|spotted|notice|"
    r"noticed|observe|observed|look at|looked at)\b"
    r"|\bwhat\s+(?:(?:objects|things)\s+)?you\s+(?:just\s+)?(?:saw|spotted|noticed|observed|"
    r"have seen|'ve seen)\b"
    r"|\b(?:did|have) you (?:see|seen|spot|spotted|notice|noticed) (?:anything|something|"
    r"any(?:one|body)|things)\b"
    r"|\bwhat (?:was|were) (?:in front of you|you looking at|in view|on (?:your )?camera)\b"
    r"|\bwhat (?:objects|things|stuff) (?:did|have) you (?:see|seen|spot|spotted|notice|noticed)\b"
    r"|\bwhat (?:did|had) (?:your camera|the camera|you) (?:pick up|catch|detect|see)\b"
    r"|\bwhich (?:objects|things) (?:did|have) you (?:see|seen|spot|spotted)\b"
    r"|\b(?:what )?(?:do|can) you remember (?:seeing|spotting|noticing|from|about)\b"
    r"|\bwhat (?:objects |things |stuff )?(?:was|were) (?:there |lying |standing )?"
    r"(?:in|at|on|inside) (?!front of\b)"
    r"|\bwhat (?:objects|things) (?:are|were) (?:there|around)\b"
    r"|^(?:was|were) there (?:anything|anyone|anybody|something|someone|somebody)\b"
)
# "anything at the reception earlier?", "anyone in the kitchen at 3 pm?": a digest of what was
# seen there, when a time in the past is said (without one it may be a request to go and look)
_ANYTHING_AT = re.compile(
    r"^(?:(?:and|so|but)\s+)?(?:(?:did you see|you see|see|seen|saw)\s+)?(?:anything|anyone|"
    r"anybody|something|someone|somebody)(?: (?:interesting|unusual|new|else|at all))?"
    r" (?:in|at|on|inside|near|by) "
)
_PAST_MARK = re.compile(r"\b(?:earlier|before|ago|yesterday|previously|so far)\b")
_DIGEST = re.compile(
    r"\bwhat(?:'s| has| had|'d)?\s+(?:just\s+)?(?:happened|happening|been happening|been going on|"
    r"went on|going on)\b"
    r"|\bwhat (?:did|have) you (?:do|done|been doing|been up to|get up to|got up to)\b"
    r"|\bwhat (?:were|was) you (?:doing|up to)\b"
    r"|\banything (?:happen|happened|new|interesting|going on|to report)\b"
    r"|\bdid anything (?:happen|interesting happen)\b"
    r"|\bwhat(?:'s| is) new\b|\bgive me (?:a |an )?(?:summary|recap|rundown|update)\b"
    r"|\b(?:summari[sz]e|recap)\b|\bwhat did i miss\b|\bcatch me up\b|\bfill me in\b"
    r"|\bbring me up to (?:date|speed)\b|\bwhat went on\b"
)
_POSE_AT = re.compile(
    r"\bwhere\s+(?:were|was)\s+(?:you|the robot|it)\b|\bwhich (?:room|place|location) were you"
    r"|\bwhere had you been\b|\bwhat were you (?:doing|up to)\b|\bwhere did you be\b"
)
_VISITS = re.compile(
    r"\bwhere (?:have|did) you (?:been|go|gone|drive|driven|went)\b"
    r"|\bwhich (?:places|rooms) (?:did|have) you (?:visit|visited|go to|been to|drive to)"
    r"|\bwhere all (?:have|did) you\b"
)
_SHORTHAND = {"u": "you", "ya": "you", "ur": "your", "r": "are", "pls": "please", "plz": "please"}
# the words people use for what the detectors call otherwise
_SAME_THING = {
    "package": "parcel", "packages": "parcel", "parcels": "parcel", "someone": "person",
    "somebody": "person", "people": "person", "persons": "person", "mobile": "cell phone",
    "cellphone": "cell phone", "mobile phone": "cell phone", "television": "tv",
    "couch": "sofa", "mugs": "mug", "cups": "cup",
}  # fmt: skip
_HOURS = {
    "one": 1, "two": 2, "three": 3, "four": 4, "five": 5, "six": 6, "seven": 7, "eight": 8,
    "nine": 9, "ten": 10, "eleven": 11, "twelve": 12,
}  # fmt: skip
_HOUR = r"(?:1[0-2]|0?[1-9]|" + "|".join(_HOURS) + ")"
_MINUTES = {"five": 5, "ten": 10, "twenty": 20, "twenty five": 25, "twenty-five": 25}
_DAYPART = r"(?=\s+in the (?:morning|afternoon|evening))"
# "half past two", "ten past four", "twenty to three", "25 minutes past 3", "quarter of five",
# "four o'clock", "3 pm", "three in the afternoon", "9:15 in the evening"; not a range ("from
# ten to eleven") and not a duration ("five to ten minutes ago")
_SPOKEN_CLOCK = re.compile(
    rf"(?<!from )(?<!between )\b(?:(?P<part>half|quarter|twenty[- ]five|twenty|ten|five"
    rf"|(?P<digits>[1-5]?\d))(?P<unit> minutes?)? (?P<rel>past|after|to|till|til|before|of)"
    rf" (?P<h>{_HOUR})(?:\s*(?P<m1>am|pm))?"
    rf"|(?P<h2>{_HOUR}) o'?clock|(?P<h3>{_HOUR}) (?P<m3>am|pm)"
    rf"|(?P<h4>{_HOUR}){_DAYPART}|(?P<h6>{_HOUR}):(?P<m6>[0-5]\d){_DAYPART})\b"
    r"(?!\s*(?:minutes?|mins?|hours?|hrs?|seconds?|secs?|times|[hms])\b)"
    r"(?:\s+in the (?P<daypart>morning|afternoon|evening))?"
)
_BETWEEN = re.compile(
    r"\b(?:between|from)\s+(?P<a>\d{1,2}(?::\d{2})?(?:\s*(?:am|pm))?)\s+(?:and|to|till|until)\s+"
    r"(?P<b>\d{1,2}(?::\d{2})?(?:\s*(?:am|pm))?)(?![\w:])"
)
_NOTHING = {"anything", "something", "things", "much", "anyone", "anybody", "it", "that", "them"}
_OBJECT_TAIL = re.compile(
    r"(?:\s*,?\s*(?:and|or)\s+(?:when|where|how|what|for how long)\b.*"
    r"|\s+(?:the\s+)?(?:last|first)(?:\s+time)?\b.*|\s+most recently\b.*"
    r"|\s+(?:recently|lately|before|earlier|yet|today|at all|anywhere|around|ever|"
    r"this morning|this afternoon|please|again)\b.*"
    r"|\s+(?:is|are|was|were|for)$)"
)
# "and before that?", "and an hour before that?", "what about 10 minutes earlier?"
_BEFORE_THAT = re.compile(
    r"^(?:(?:and|so|ok|okay|but|then)\s+)?(?:(?:what|how) about\s+)?"
    rf"(?:(?P<half>half an? (?:hour|minute))\s+|(?P<n>{_NUMBER})\s*(?P<unit>{_UNIT})\s+)?"
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
# "at about 3:30", "at roughly half past two": a hedge before a time, never a place
_HEDGES = frozenset(
    ("about", "around", "roughly", "approximately", "approx", "circa", "nearly", "almost",
     "exactly", "precisely", "sometime", "some", "just", "like", "ish")
)  # fmt: skip
_HEDGE = r"(?:" + "|".join(sorted(_HEDGES)) + r"|at (?:" + "|".join(sorted(_HEDGES)) + r"))\b"
_PLACE_TAIL = re.compile(r"\s+(?:in|at|inside|near|by)\s+(?:the\s+|my\s+|our\s+)?(?P<place>.+)$")
_ARTICLE = re.compile(r"^(?:the|a|an|my|our|some|any|your|her|his|their|that|this)\s+")


@dataclass(frozen=True)
class Recall:
    """A question about the past as one episodic call; ``said``: the time as the robot restates it
    ("around 30 s ago", "in the last 10 minutes"), ``obj``/``place``: what and where was asked."""

    kind: RecallKind
    tool: str
    arguments: dict[str, Any] = field(default_factory=dict)
    said: str = ""
    obj: str | None = None
    place: str | None = None
    since_turn: bool = False  # start at the person's previous turn, when it is known
    first: bool = False  # last_seen: the earliest sighting on record is asked for, not the last
    around: bool = False  # a window around a clock time: the answer says the server's window
    offer: bool = False  # "where is X": the answer offers to go and look (asks, never moves)

    def code(self) -> str:
        """The phrasing sets' label: answer:history | answer:last_seen | answer:pose_at."""
        if self.tool == LAST_SEEN:
            return "last_seen"
        if self.tool == POSE_AT:
            return "pose_at"
        return "history"


def read_recall(text: str) -> Recall | None:
    """The question about the past in ``text``, or None (not one, or not sure); a typo in the
    question word or the verb ("wher did you see", "did you sea") is read past when the
    question reads no other way."""
    clean = _clean(text)
    if not clean:
        return None
    recall = _read(clean)
    if recall is None and (fixed := _typos_fixed(clean)) != clean:
        recall = _read(fixed)
    return recall


def _read(clean: str) -> Recall | None:
    for reader in (_pose_at, _last_seen, _seen, _visits, _digest):
        recall = reader(clean)
        if recall is not None:
            return recall
    return None


# the grammar's own function words a typo is corrected to: the word that opens the question,
# and the verb after "you"; never an object's name (the memory corrects those to labels it holds)
_OPENING_WORDS = ("where", "what", "when", "which", "have", "did", "were")
_VERBS = ("see", "seen", "saw", "spot", "spotted", "notice", "noticed", "last")
_TYPO_CUTOFF = 0.85  # one letter dropped, added or swapped in a short word ("wher", "wat")
_RUN_TOGETHER = {"wheres": "where's", "whats": "what's", "whens": "when's"}


def _typos_fixed(clean: str) -> str:
    words = clean.split()
    for i, word in enumerate(words):
        if i == 0:
            words[i] = _RUN_TOGETHER.get(word) or _closest(word, _OPENING_WORDS)
        elif words[i - 1] == "you":
            words[i] = _closest(word, _VERBS)
    return " ".join(words)


def _closest(word: str, vocabulary: tuple[str, ...]) -> str:
    """``word``, or the one vocabulary word at least :data:`_TYPO_CUTOFF` alike (ties: none)."""
    if word in vocabulary or len(word) < 3 or not word.isalpha():
        return word
    scored = sorted(((SequenceMatcher(None, word, v).ratio(), v) for v in vocabulary), reverse=True)
    best = [v for ratio, v in scored if ratio >= _TYPO_CUTOFF and ratio == scored[0][0]]
    return best[0] if len(best) == 1 else word


def _clean(text: str) -> str:
    """Lower case, chatty openers dropped ("yo, ...", "hey robot, ...", "ok so ..."), texting
    shorthand spelled out ("u seen" → "you seen"), clock words as digits ("half past two" →
    "2:30")."""
    clean = normalise(text).strip(" .!?")
    clean = _OPENER.sub("", clean)
    clean = " ".join(_SHORTHAND.get(w, w) for w in clean.split())
    clean = _ROBOT_SUBJECT.sub(_as_you, _SEEING.sub(_plain_seeing, clean))
    return _SPOKEN_CLOCK.sub(_clock_digits, clean)


# Other verbs of seeing, said after their subject ("did you catch sight of", "have you come
# across", "when did it last lay eyes on"), read as see / saw / seen: the auxiliary before the
# verb picks the form ("have you come across" → "have you seen", "did you run into" → "did you
# see"). Only after a subject, so "run into the kitchen" stays a request's words.
_SEEING_FORMS = {
    "base": r"catch sight of|catch a glimpse of|get a glimpse of|glimpse|lay eyes on|clap eyes on",
    "both": r"come across|run into|bump into|set eyes on",  # base and participle alike
    "past": r"caught sight of|caught a glimpse of|got a glimpse of|glimpsed|laid eyes on"
    r"|clapped eyes on|came across|ran into|bumped into",
}
_ROBOT = r"(?:the robot|the bot|this robot|our robot|your robot|robot|it)"
_SEEING = re.compile(
    rf"\b(?P<subject>you|{_ROBOT})\s+(?P<adverb>(?:last|first|ever|just|already|recently|"
    r"actually|most recently)\s+)?(?:"
    + "|".join(f"(?P<{form}>{verbs})" for form, verbs in _SEEING_FORMS.items())
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


def _as_you(match: re.Match[str]) -> str:
    return f"{_SECOND_PERSON.get(match['aux'], match['aux'])} you"


_SECOND_PERSON = {"has": "have", "does": "do"}


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


_OPENER = re.compile(
    r"^(?:(?:yo|hey|hi|hello|ok|okay|so|well|um+|uh+|erm|oh|alright|robot)\b[\s,;:!.-]*)+"
    r"(?=\S)"
)


def _clock_digits(match: re.Match[str]) -> str:
    hour_text = match["h"] or match["h2"] or match["h3"] or match["h4"] or match["h6"]
    hour = int(hour_text) if hour_text.isdigit() else _HOURS[hour_text]
    minute = int(match["m6"] or 0)
    if match["rel"]:
        part, rel = match["part"], match["rel"]
        if (rel == "of" and part != "quarter") or (
            match["digits"] and not match["unit"] and rel not in ("past", "after")
        ):  # "two of three", "10 to 11": not a clock time
            return match[0]
        minute = int(part) if match["digits"] else {"half": 30, "quarter": 15}.get(part, 0)
        minute = minute or _MINUTES[part]
        if not 0 < minute < 60:
            return match[0]
        if rel in ("to", "till", "til", "before", "of"):
            hour, minute = (hour - 2) % 12 + 1, 60 - minute
    meridiem = (match["m1"] or match["m3"] or "") or {
        "morning": "am", "afternoon": "pm", "evening": "pm"
    }.get(match["daypart"] or "", "")  # fmt: skip
    return f"{hour}:{minute:02d}{meridiem}" if minute or not meridiem else f"{hour}{meridiem}"


def looks_like_recall(text: str) -> bool:
    """A question about the past the grammar could not read: it gets an honest "I did not
    understand" (never an action read from it). "and before that?" with nothing earlier to step
    back from is one too."""
    clean = _typos_fixed(_clean(text)) if text.strip() else ""
    return bool(_PAST_QUESTION.search(clean) or _BEFORE_THAT.match(clean))


def follow_up_recall(
    text: str, previous: Recall, is_place: Callable[[str], bool] | None = None
) -> Recall | None:
    """A short follow-up to a question about the past, read against it: "and the laptop?",
    "what about 2:24 pm?", "and in the mailroom?", "where was that?". ``is_place``: whether a
    phrase names one of the map's places ("the reception"): after a question about what was
    seen or happened, "what about the reception?" asks about that place, not a thing called
    "reception"."""
    clean = _clean(text)
    if _AGAIN.match(clean):
        return previous
    before = _BEFORE_THAT.match(clean)
    if before is not None:
        return _before(previous, _amount_of(before))
    match = _MORE.match(clean)
    if match is None:
        return None
    rest = match["rest"]
    bare = _ARTICLE.sub("", rest).strip()
    if is_place is not None and _place_of(rest) is None and is_place(bare):
        if previous.tool == WHAT_HAPPENED:  # "what about the reception?": the same, there
            return replace(previous, arguments={**previous.arguments, "place": bare}, place=bare)
        if previous.tool == LAST_SEEN and previous.obj:
            return _last_seen(f"when did you last see {previous.obj} in {bare}")
        return None  # "where were you at 3 pm" + "what about the kitchen?": not guessed
    if previous.kind == "pose_at" and (_clock(rest) or _ago(rest)):
        return _pose_at(f"where were you {rest}")
    if previous.tool == WHAT_HAPPENED and (
        _span(rest) or _ago(rest) or _place_of(rest) or _clock(rest)
    ):
        kinds = previous.arguments.get("kinds")
        said = {"seen": "what did you see", "visits": "where did you go"}.get(
            previous.kind, "what happened"
        )
        recall = _window(f"{said} {rest}", kinds, previous.kind, default=None)
        if recall is not None and recall.place and not (_span(rest) or _ago(rest) or _clock(rest)):
            window = {k: v for k, v in previous.arguments.items() if k in ("start", "end")}
            arguments = {**recall.arguments, **window}
            return replace(recall, arguments=arguments, said=previous.said)
        return recall
    if previous.kind not in ("last_seen", "seen") or _place_of(rest) or _clock(rest):
        return None
    if _ago(rest) or _span(rest):
        return None
    return _last_seen(f"when did you last see {rest}")  # "and the laptop?": another thing


def _amount_of(match: re.Match[str]) -> int | None:
    """Seconds said in "(an hour) before that", None when no amount was said."""
    if match["half"]:
        return 1800 if "hour" in match["half"] else 30
    if match["n"]:
        return _number(match["n"]) * _UNIT_S[match["unit"][0]]
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
    said = f"{_amount(back)} earlier"
    return replace(previous, arguments=arguments, said=said, around=True)


_TIME = re.compile(r"(?P<base>[^+-]+?)(?:\s*(?P<sign>[+-])\s*(?P<n>\d+)(?P<unit>[smh]))?")


def _relative(time: str) -> int | None:
    """Seconds before now of a relative time (``-3600s``), else None."""
    match = re.fullmatch(r"-(\d+)([smh])", time.strip())
    return int(match[1]) * _UNIT_S[match[2]] if match else None


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
    offset = int(match["n"] or 0) * _UNIT_S[match["unit"] or "s"]
    offset = -offset if match["sign"] == "-" else offset
    offset -= back
    base = match["base"].strip()
    return base if offset == 0 else f"{base} {'-' if offset < 0 else '+'}{abs(offset)}s"


def _said_time(time: str) -> str:
    """How an answer restates a shifted time: "2 hours ago", "an hour before 4:31 pm"."""
    seconds = _relative(time)
    if seconds is not None:
        return f"{_amount(seconds)} ago"
    match = _TIME.fullmatch(time)
    if match is None or not match["n"]:
        return f"at {_said_clock(time.strip())}"
    said = f"{_amount(int(match['n']))} {'before' if match['sign'] == '-' else 'after'}"
    return f"{said} {_said_clock(match['base'].strip())}"


def _amount(seconds: int) -> str:
    """ "an hour", "a minute", "2 hours", "90 seconds"."""
    return {60: "a minute", 3600: "an hour"}.get(seconds) or _spoken(seconds)


def default_recall() -> Recall:
    """What a question about the past that only the meaning matcher understood gets: the
    digest since the person's previous turn (else the last hour)."""
    return _away()


# --- the readers -----------------------------------------------------------------------------
def _pose_at(text: str) -> Recall | None:
    if not _POSE_AT.search(text):
        return None
    clock = _clock(text)
    if clock is not None:
        return Recall("pose_at", POSE_AT, {"time": clock}, f"at {clock}")
    ago = _ago(text)
    if ago is not None:
        seconds, said = ago
        return Recall("pose_at", POSE_AT, {"time": f"-{seconds}s"}, said)
    return None


def _last_seen(text: str) -> Recall | None:
    still = _IS_STILL.match(text)
    phrase = None
    if still is not None:
        rest = still["rest"]
        phrase = still["obj"] if rest == "there" else f"{still['obj']} {rest}"
    for pattern in _LAST_SEEN:
        if phrase is not None:
            break
        match = pattern.search(text)
        if match is not None:
            phrase = match["obj"]
    now = _WHERE_NOW.match(text) if phrase is None else None
    if now is not None:
        phrase = now["obj"]
    if phrase is None:
        return None
    obj, place = _object(phrase)
    if obj is None:
        return None
    obj = _SAME_THING.get(obj, obj)
    arguments: dict[str, Any] = {"query": obj}
    if place is not None:
        arguments["place"] = place
    first = bool(re.search(r"\bfirst\b", text))
    if first:
        arguments["n"] = _FIRST_OF
    offer = now is not None
    return Recall("last_seen", LAST_SEEN, arguments, obj=obj, place=place, first=first, offer=offer)


def _seen(text: str) -> Recall | None:
    if not (
        _SEEN.search(text) or (_ANYTHING_AT.search(text) and _place_of(text) and _in_the_past(text))
    ):
        return None
    return _window(text, ["sightings"], "seen", default=("-1h", "in the last hour"))


def _in_the_past(text: str) -> bool:
    """A time in the past is said: an amount ago, the last N, a clock time, today, earlier."""
    return bool(
        _PAST_MARK.search(text) or _ago(text) or _span(text) or _clock(text)
        or _TODAY.search(text) or _RECENT.search(text) or _BETWEEN.search(text)
    )  # fmt: skip


def _visits(text: str) -> Recall | None:
    if not _VISITS.search(text):
        return None
    return _window(text, ["places"], "visits", default=("-1h", "in the last hour"))


def _digest(text: str) -> Recall | None:
    if _AWAY.search(text):
        return _away()
    if not _DIGEST.search(text):
        return None
    recall = _window(text, None, "digest", default=None)
    return recall or _away()


def _away() -> Recall:
    return Recall(
        "away", WHAT_HAPPENED, {"start": DEFAULT_AWAY, "max_items": 100}, "while away",
        since_turn=True,
    )  # fmt: skip


def _window(
    text: str, kinds: list[str] | None, kind: RecallKind, default: tuple[str, str] | None
) -> Recall | None:
    """The time range a question names: "N ago" (a window around it), "in the last N", "today";
    else ``default`` (start, how it is said)."""
    place = _place_of(text)
    arguments: dict[str, Any] = {"max_items": 100}
    if kinds is not None:
        arguments["kinds"] = kinds
    if place is not None:
        arguments["place"] = place
    between = _BETWEEN.search(text)
    if between is not None:
        start, end = _clock_range(between["a"], between["b"])
        arguments["start"], arguments["end"] = start, end
        return Recall(kind, WHAT_HAPPENED, arguments, f"between {start} and {end}", place=place)
    span = _span(text)
    ago = _ago(text) if span is None else None
    if _AWAY.search(text):
        arguments["start"] = DEFAULT_AWAY
        return Recall(kind, WHAT_HAPPENED, arguments, "while away", place=place, since_turn=True)
    if span is not None:
        seconds, said = span
        arguments["start"] = f"-{seconds}s"
    elif ago is not None:
        seconds, said = ago
        half = max(15, seconds // 2)  # a window around the moment asked about
        arguments["start"] = f"-{seconds + half}s"
        if seconds - half > 0:
            arguments["end"] = f"-{seconds - half}s"
        said = f"around {said}"
    elif (clock := _clock(text)) is not None:  # "at 3 pm": 5 minutes either side of it
        arguments["start"], arguments["end"] = f"{clock} -{AROUND}", f"{clock} +{AROUND}"
        said = f"around {_said_clock(clock)}"
        return Recall(kind, WHAT_HAPPENED, arguments, said, place=place, around=True)
    elif _TODAY.search(text):
        arguments["start"], said = "00:00", "today"
    elif _RECENT.search(text):
        arguments["start"], said = "-10m", "in the last 10 minutes"
    elif place is not None and kind == "seen":  # "what was in the kitchen": the last day there
        arguments["start"], said = "-24h", "in the last 24 hours"
    elif default is not None:
        arguments["start"], said = default
    else:
        return None
    return Recall(kind, WHAT_HAPPENED, arguments, said, place=place)


# --- slots -----------------------------------------------------------------------------------
def _number(text: str) -> int:
    return int(text) if text.isdigit() else _NUMBERS[text]


def _ago(text: str) -> tuple[int, str] | None:
    """Seconds before now, and how it was said ("30 s ago")."""
    match = _AGO.search(text)
    if match is None:
        return None
    if match["moment"]:
        return 10, "just now"
    if match["half"]:
        seconds = 1800 if "hour" in match["half"] else 30
    else:
        seconds = _number(match["n"]) * _UNIT_S[match["unit"][0]]
    said = {60: "a minute", 3600: "an hour"}.get(seconds, _spoken(seconds))
    return seconds, f"{said} ago"


def _span(text: str) -> tuple[int, str] | None:
    match = _SPAN.search(text)
    if match is None:
        return None
    if match["half"] or match["quarter"]:
        seconds = 1800 if match["half"] else 900
    else:
        seconds = (_number(match["n"]) if match["n"] else 1) * _UNIT_S[match["unit"][0]]
    return seconds, f"in the last {_spoken(seconds)}"


def _spoken(seconds: int) -> str:
    if seconds % 3600 == 0:
        hours = seconds // 3600
        return "hour" if hours == 1 else f"{hours} hours"
    if seconds % 60 == 0:
        minutes = seconds // 60
        return "minute" if minutes == 1 else f"{minutes} minutes"
    return f"{seconds} seconds"


def _clock(text: str) -> str | None:
    """The clock time as said, in a form the server reads (``3pm``, ``15:30``, ``12:00``)."""
    match = _CLOCK.search(text)
    if match is None:
        return None
    clock = match["clock"].replace(".", "").replace(" ", "")
    return _meridiem({"noon": "12:00", "midday": "12:00", "midnight": "00:00"}.get(clock, clock))


def _said_clock(clock: str) -> str:
    """``3pm`` → ``3 pm``, ``2:30pm`` → ``2:30 pm``, ``15:30`` as is."""
    return re.sub(r"(\d)(am|pm)$", r"\1 \2", clock)


def _meridiem(clock: str) -> str:
    """A 12-hour clock said without am/pm ("half past two", "2:30") is read as people at work
    mean it: 1 to 7 and 12 in the afternoon, 8 to 11 in the morning. The answer restates the
    time the server used, so the reading is visible."""
    match = re.fullmatch(r"(\d{1,2}):(\d{2})", clock)
    if match is None:
        return clock
    hour = int(match[1])
    if not 1 <= hour <= 12 or match[1].startswith("0"):
        return clock
    return f"{clock}{'am' if 8 <= hour <= 11 else 'pm'}"


def _clock_range(a: str, b: str) -> tuple[str, str]:
    """ "3:30 and 3:35 pm": the am/pm said once holds for both ends."""
    a, b = a.replace(" ", ""), b.replace(" ", "")
    said = re.search(r"(am|pm)$", b)
    if said and not re.search(r"(am|pm)$", a):
        a += said[1]
    return _meridiem(a if ":" in a or a[-2:] in ("am", "pm") else f"{a}:00"), _meridiem(
        b if ":" in b or b[-2:] in ("am", "pm") else f"{b}:00"
    )


def _place_of(text: str) -> str | None:
    match = re.search(
        r"\b(?:in|at|inside)\s+(?!(?:the\s+)?(?:last|past|previous|moment)\b)"
        r"(?:the\s+|my\s+|our\s+)?(?P<place>[a-z' ]+?)"
        r"(?=\s+(?:today|recently|lately|earlier|in the|during|over|this|\d|a |an |half|just|"
        r"around|when|while|between|from|before|after|at (?:\d|noon|midday|midnight)|"
        + _HEDGE
        + r")|$)",
        text,
    )
    if match is None:
        return None
    place = match["place"].strip()
    words = place.split()
    clock_words = ("noon", "midday", "midnight")
    if (
        not words
        or words[0] in ("all", "view", *clock_words, *_HEDGES)
        or words[:2] in (["front"], ["front", "of"])  # "in front of you" is no place
        or _ago(place)
        or _span(place)
    ):
        return None
    return place


def _object(phrase: str) -> tuple[str | None, str | None]:
    """What to look up, and the place it was asked about ("the mug in the kitchen")."""
    obj = phrase.strip(" ,.?!")
    obj = _AGO.sub("", obj).strip()
    obj = _SPAN.sub("", obj).strip()
    obj = _OBJECT_TAIL.sub("", obj).strip(" ,")
    place = None
    where = _PLACE_TAIL.search(obj)
    if where is not None:
        place = where["place"].strip()
        obj = obj[: where.start()].strip()
    obj = _ARTICLE.sub("", obj).strip()
    obj = re.sub(r"^(?:any|one|ones)\s+", "", obj).strip()
    if not obj or obj in _NOTHING or len(obj.split()) > 5:
        return None, None
    return obj, place
