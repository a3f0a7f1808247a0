"""The places ``navigation.list_locations`` lists, by every spelling (names and aliases)."""

from __future__ import annotations

import json
import re
from dataclasses import dataclass, field


@dataclass
class Locations:
    """Names and aliases from ``navigation.list_locations``."""

    names: dict[str, str] = field(default_factory=dict)  # spelling → canonical name

    @classmethod
    def from_result(cls, text: str) -> Locations:
        try:
            data = json.loads(text)
        except ValueError:
            data = None
        items = data.get("locations", []) if isinstance(data, dict) else []
        found = cls()
        for item in items if isinstance(items, list) else []:
            if not isinstance(item, dict) or not isinstance(item.get("name"), str):
                continue
            name = item["name"]
            for spelling in [name, *[a for a in item.get("aliases", []) if isinstance(a, str)]]:
                found.names[_key(spelling)] = name
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
