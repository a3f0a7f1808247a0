"""What a typed or spoken command asks for: a pure parse of the words, no tools involved.

Understood: "go / drive / head / navigate to <place>", "find / look for / search for <thing>
[in the <place>]", "what do you see", "watch for <thing>", "fetch / bring / get <thing>
from <place>", and for the arm: "pick up / grab <thing> [at <place>]" (with a place: a fetch),
"put / place / set <it | thing> [down] [on / at / in <place>]", "hand it over / drop it / give it
to me / let go". Anything else is ``unknown`` and the planner says so. The grammar is data:
``config/commands.yaml``.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Literal

from robot_language.config_file import CONFIG, Regex, Strict, read_model
from robot_language.normalise import normalise

Kind = Literal["goto", "find", "see", "watch", "fetch", "pick", "put", "release", "unknown"]


class _Command(Strict):
    kind: Kind
    pattern: Regex


class Grammar(Strict):
    """``config/commands.yaml``: the command grammar, tried in order."""

    polite: Regex
    tail: Regex
    commands: list[_Command]


GRAMMAR = read_model(CONFIG / "commands.yaml", Grammar, "commands")


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
        words = GRAMMAR.tail.sub("", GRAMMAR.polite.sub("", candidate.strip()))
        for command in GRAMMAR.commands:
            kind, match = command.kind, command.pattern.match(words)
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
