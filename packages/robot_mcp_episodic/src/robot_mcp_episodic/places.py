"""The map's named locations: where a pose is (the nearest named location within a radius)
and which pose a name means (names and aliases, case and separator insensitive)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml


class UnknownPlaceError(ValueError):
    """A place name that is not on the map; the message lists the known ones."""


@dataclass(frozen=True)
class Place:
    name: str
    x: float
    y: float
    aliases: tuple[str, ...] = ()


def _key(name: str) -> str:
    return "_".join(name.strip().lower().replace("-", " ").replace("_", " ").split())


class Places:
    def __init__(self, map_name: str, places: list[Place], radius_m: float = 2.5) -> None:
        self.map = map_name
        self.radius_m = radius_m
        self._places = places
        self._by_key: dict[str, Place] = {}
        for place in places:
            for name in (place.name, *place.aliases):
                self._by_key[_key(name)] = place

    @classmethod
    def from_yaml(cls, path: Path, radius_m: float = 2.5) -> Places:
        data: Mapping[str, Any] = yaml.safe_load(path.read_text(encoding="utf-8")) or {}
        locations: Mapping[str, Any] = data.get("locations") or {}
        places = [
            Place(
                str(name),
                float(spot["x"]),
                float(spot["y"]),
                tuple(str(alias) for alias in spot.get("aliases") or ()),
            )
            for name, spot in locations.items()
        ]
        return cls(str(data.get("name") or path.stem), places, radius_m)

    def names(self) -> list[str]:
        return [place.name for place in self._places]

    def locate(self, x: float, y: float) -> str | None:
        """The nearest named location within ``radius_m`` of (x, y), else None."""
        best: tuple[float, str] | None = None
        for place in self._places:
            distance = math.hypot(place.x - x, place.y - y)
            if distance <= self.radius_m and (best is None or distance < best[0]):
                best = (distance, place.name)
        return best[1] if best else None

    def position(self, name: str) -> tuple[float, float]:
        """(x, y) of a named place (an alias works too)."""
        place = self._by_key[_key(self.resolve(name))]
        return place.x, place.y

    def resolve(self, name: str) -> str:
        """The canonical name of ``name`` (an alias works too); UnknownPlaceError if none."""
        place = self._by_key.get(_key(name))
        if place is None:
            raise UnknownPlaceError(
                f"{name!r} is not a named place on the map {self.map!r}; known places: "
                + ", ".join(self.names())
            )
        return place.name
