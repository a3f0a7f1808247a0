"""The places ``navigation.list_locations`` lists, by every spelling (names and aliases)."""

from __future__ import annotations

import re
from dataclasses import dataclass, field

from robot_language.places import PlaceIndex


@dataclass
class Locations:
    """Names and aliases from ``navigation.list_locations``."""

    names: dict[str, str] = field(default_factory=dict)  # spelling → canonical name

    @classmethod
    def from_result(cls, text: str) -> Locations:
        found = cls()
        for place in PlaceIndex.from_result(text).places:
            for spelling in (place.name, *place.aliases):
                found.names[_key(spelling)] = place.name
        return found

    def resolve(self, phrase: str) -> str | None:
        key = _key(phrase)
        if key in self.names:
            return self.names[key]
        # "the kitchen area" / "kitchen please": a known name inside the phrase
        hits = [name for spelling, name in self.names.items() if spelling and spelling in key]
        return max(hits, key=len) if hits else None

    def known(self) -> list[str]:
        return sorted(set(self.names.values()))


def _key(text: str) -> str:
    return re.sub(r"[\s_\-]+", " ", text.lower()).strip()
