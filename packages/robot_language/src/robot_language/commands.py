"""What a typed or spoken command asks for: a pure parse of the words, no tools involved.

Understood: "go / drive / head / navigate to <place>", "find / look for / search for <thing>
[in the <place>]", "what do you see", "watch for <thing>", "fetch / bring / get <thing>
from <place>", and for the arm: "pick up / grab <thing> [at <place>]" (with a place: a fetch),
"put / place / set <it | thing> [down] [on / at / in <place>]", "hand it over / drop it / give it
to me / let go". Anything else is ``unknown`` and the planner says so.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Literal

from robot_language.normalise import normalise

Kind = Literal["goto", "find", "see", "watch", "fetch", "pick", "put", "release", "unknown"]

_ARTICLE = r"(?:(?:the|a|an|my|our|some)\s+)?"
_POLITE = re.compile(
    r"^(?:(?:please|robot|hey robot|ok|okay|now|then|and|could you|can you|would you|"
    r"will you|i want you to|i'd like you to)[\s,]+)+"
)
_TAIL = re.compile(r"\s*(?:[.!?:;]|,\s*please|\s+please|\s+and\s+(?:tell|report|let)\b).*$")
_PATTERNS: list[tuple[Kind, re.Pattern[str]]] = [
    (
        "fetch",
        re.compile(
            rf"^(?:fetch|bring(?:\s+me)?|get(?:\s+me)?|pick\s+up|collect|grab)\s+{_ARTICLE}"
            rf"(?P<obj>.+?)\s+from\s+{_ARTICLE}(?P<place>.+)$"
        ),
    ),
    (
        "pick",
        re.compile(
            rf"^(?:pick\s+up|grab|take\s+hold\s+of)\s+{_ARTICLE}(?P<obj>.+?)"
            rf"(?:\s+(?:in|at|from|on)\s+{_ARTICLE}(?P<place>.+))?$"
        ),
    ),
    (
        "put",
        re.compile(
            rf"^(?:put|place|set|leave)\s+(?:it|that|this|{_ARTICLE}(?P<obj>.+?))"
            rf"(?:\s+(?:back\s+)?down)?(?:\s+(?:here|there))?"
            rf"(?:\s+(?:on|at|in|onto|into)\s+{_ARTICLE}(?P<place>.+))?$"
        ),
    ),
    (
        "release",
        re.compile(
            r"^(?:hand\s+(?:it|that|this|(?:the\s+)?\w+(?:\s+\w+)?)\s+over|hand\s+over\b.*|"
            # "give me the mug" hands over what is held; "give me a description of the room"
            # is not a hand-over (a thing of at most two words, no phrase after it)
            r"give\s+(?:it|that|this|me\s+(?:the\s+|a\s+|an\s+|my\s+)?\w+(?:\s+\w+)?|.+\s+to\s+me)|"
            r"drop\s+(?:it|that|this|.+)|"
            r"let\s+(?:it\s+|that\s+)?go)(?:\s+(?:here|now|to\s+me))?$"
        ),
    ),
    (
        "see",
        re.compile(
            r"^(?:what\s+(?:do|can)\s+you\s+see|what'?s?\s+in\s+front\s+of\s+you|"
            r"look\s+around|describe\s+(?:the\s+)?(?:scene|what you see))\b"
        ),
    ),
    (
        "watch",
        re.compile(rf"^(?:watch|keep\s+an\s+eye|wait)\s+(?:out\s+)?for\s+{_ARTICLE}(?P<obj>.+)$"),
    ),
    (
        "find",
        re.compile(
            rf"^(?:find|look\s+for|search\s+for|locate|where\s+is)\s+{_ARTICLE}(?P<obj>.+?)"
            rf"(?:\s+(?:in|at)\s+{_ARTICLE}(?P<place>.+))?$"
        ),
    ),
    (
        "goto",
        re.compile(
            rf"^(?:go|drive|head|move|navigate|return|come)\s+(?:back\s+)?(?:over\s+)?"
            rf"(?:to|into)\s+{_ARTICLE}(?P<place>.+)$"
        ),
    ),
]


@dataclass(frozen=True)
class Command:
    kind: Kind
    text: str
    obj: str | None = None
    place: str | None = None
    to: str | None = None  # fetch: where to bring it (a leg the understanding layer adds)

    def describe(self) -> str:
        """What was understood, in words ("find 'scissors' in 'kitchen'")."""
        parts: list[str] = [self.kind]
        if self.obj:
            parts.append(repr(self.obj))
        if self.place:
            parts.append(f"at {self.place!r}")
        if self.to:
            parts.append(f"to {self.to!r}")
        return " ".join(parts)


def parse(text: str) -> Command:
    """The first command found in ``text`` (the part before a colon is tried first, so a
    restated instruction "Fetch the package from the mailroom: drive …" parses)."""
    clean = normalise(text, spoken=False)
    for candidate in (clean.split(":", 1)[0], *re.split(r"(?<=[.!?])\s+", clean)):
        words = _TAIL.sub("", _POLITE.sub("", candidate.strip()))
        for kind, pattern in _PATTERNS:
            match = pattern.match(words)
            if match is not None:
                groups = match.groupdict()
                obj, place = _strip(groups.get("obj")), _strip(groups.get("place"))
                if kind == "pick" and place is not None:
                    kind = "fetch"  # "pick up the parcel at the mailroom": go there first
                if kind == "release":
                    obj = None  # what is held; the arm's server knows
                return Command(kind, text, obj, place)
    return Command("unknown", text)


def _strip(value: str | None) -> str | None:
    if value is None:
        return None
    value = re.sub(r"^(?:the|a|an)\s+", "", value.strip(" ,.!?"))
    return value or None
