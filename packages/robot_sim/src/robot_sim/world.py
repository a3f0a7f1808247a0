"""The world file: the navigation map plus what the camera sees at each of its places.

The map (locations, speed, start, ``failures:``) is read with the navigation server's own
loader, so the sim and ``robot-mcp-navigation`` can never disagree about where things are.
The world adds an object catalogue (shape + colour per label) and, per place, a surface and
the labels standing there. :class:`World` keeps the current contents, which change at run
time (someone took the mug) through :meth:`World.set_objects`.
"""

from __future__ import annotations

import threading
from pathlib import Path
from typing import Any, Literal

import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from robot_sim.floor.floor import Floor, load_floor
from robot_sim.floor.plan import FloorError
from robot_site_map import MapError, NavMap, load_map

Shape = Literal["mug", "bottle", "parcel", "box", "scissors", "plate", "folder"]
DoorState = Literal["open", "closed"]
RGB = tuple[int, int, int]


class WorldError(ValueError):
    """The world file (or its map) is missing, is not YAML, or is not a valid world."""


class ObjectLook(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)

    shape: Shape
    colour: RGB


MAX_OBJECTS_PER_PLACE = 6
"""A place's furniture top has six slots (3 across × 2 deep); objects never overlap."""


class PlaceSpec(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)

    surface: RGB = (150, 110, 75)
    description: str = ""
    objects: list[str] = Field(default_factory=list, max_length=MAX_OBJECTS_PER_PLACE)


class WorldSpec(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)

    map: Path
    floor: Path
    """The floor plan (walls, doors, furniture; ``robot_sim.floor``), relative to the file."""
    objects: dict[str, ObjectLook] = Field(min_length=1)
    places: dict[str, PlaceSpec] = Field(default_factory=dict)
    doors: dict[str, DoorState] = Field(default_factory=dict)
    """The doors' state at start (a door not listed is open)."""

    @model_validator(mode="after")
    def _known_labels(self) -> WorldSpec:
        for place, spec in self.places.items():
            unknown = sorted(set(spec.objects) - set(self.objects))
            if unknown:
                raise ValueError(f"place {place!r} lists unknown objects {unknown}")
        return self


def _problems(exc: ValidationError) -> str:
    return "; ".join(
        f"{'.'.join(str(p) for p in err['loc']) or '<root>'}: {err['msg']}" for err in exc.errors()
    )


def load_world(path: Path, map_path: Path | None = None) -> World:
    """Read and validate a world file and its map; every problem is a WorldError naming it.

    ``map_path`` (``SIM_MAP``) replaces the file's ``map:`` so a stack can hand the sim and
    the navigation server the same map.
    """
    try:
        data: Any = yaml.safe_load(path.read_text(encoding="utf-8"))
    except FileNotFoundError as exc:
        raise WorldError(f"world file not found: {path}") from exc
    except (OSError, yaml.YAMLError) as exc:
        raise WorldError(f"cannot read world file {path}: {exc}") from exc
    if not isinstance(data, dict):
        raise WorldError(f"{path}: the world must be a YAML mapping")
    try:
        spec = WorldSpec.model_validate(data)
    except ValidationError as exc:
        raise WorldError(f"{path}: invalid world: {_problems(exc)}") from exc
    resolved = map_path or (path.parent / spec.map)
    try:
        nav_map = load_map(resolved.resolve())
        floor = load_floor((path.parent / spec.floor).resolve())
    except (MapError, FloorError) as exc:
        raise WorldError(f"{path}: {exc}") from exc
    strangers = sorted(set(spec.places) - set(nav_map.locations))
    if strangers:
        raise WorldError(f"{path}: places {strangers} are not locations of the map {resolved}")
    unknown_doors = sorted(set(spec.doors) - set(floor.plan.doors))
    if unknown_doors:
        raise WorldError(f"{path}: doors {unknown_doors} are not doors of the floor plan")
    furnished = {f.place for f in floor.plan.furniture.values() if f.place is not None}
    strangers = sorted(furnished - set(nav_map.locations))
    if strangers:
        raise WorldError(f"{path}: furniture stands at {strangers}, not locations of the map")
    return World(spec, nav_map, floor)


class World:
    """The map, the catalogue and what stands at each place now (thread-safe)."""

    def __init__(self, spec: WorldSpec, nav_map: NavMap, floor: Floor) -> None:
        self.spec = spec
        self.map = nav_map
        self.floor = floor
        self._lock = threading.Lock()
        self._objects = {
            name: list(spec.places[name].objects) if name in spec.places else []
            for name in nav_map.locations
        }
        self._closed = frozenset(d for d, state in spec.doors.items() if state == "closed")
        self.version = 0
        """Grows with every change of contents or doors (the camera renders anew)."""
        self._held: str | None = None  # what the gripper carries (it stands nowhere meanwhile)

    @property
    def doors(self) -> list[str]:
        return list(self.floor.plan.doors)

    def closed_doors(self) -> frozenset[str]:
        with self._lock:
            return self._closed

    def set_door(self, door: str, closed: bool) -> None:
        """Close or open ``door`` (a door of the floor plan; WorldError otherwise)."""
        if door not in self.floor.plan.doors:
            raise WorldError(f"unknown door {door!r}; doors: {', '.join(self.doors)}")
        with self._lock:
            self._closed = self._closed | {door} if closed else self._closed - {door}
            self.version += 1

    @property
    def places(self) -> list[str]:
        return list(self.map.locations)

    def place(self, name: str) -> PlaceSpec:
        return self.spec.places.get(
            name, PlaceSpec(description=self.map.locations[name].description)
        )

    def objects_at(self, place: str) -> tuple[str, ...]:
        with self._lock:
            return tuple(self._objects[place])

    def set_objects(self, place: str, labels: list[str]) -> None:
        """Replace what stands at ``place``; unknown places or labels raise WorldError."""
        self.check(place, labels)
        with self._lock:
            self._objects[place] = list(labels)
            self.version += 1

    def check(self, place: str, labels: list[str]) -> None:
        """Raise WorldError unless ``labels`` may stand at ``place``."""
        if place not in self._objects:
            raise WorldError(f"unknown place {place!r}; places: {', '.join(self.places)}")
        if len(labels) > MAX_OBJECTS_PER_PLACE:
            raise WorldError(f"at most {MAX_OBJECTS_PER_PLACE} objects fit in one place")
        unknown = sorted(set(labels) - set(self.spec.objects))
        if unknown:
            raise WorldError(
                f"unknown objects {unknown}; the catalogue has: {', '.join(self.spec.objects)}"
            )

    def held(self) -> str | None:
        """What the gripper holds (a catalogue label), or None."""
        with self._lock:
            return self._held

    def set_held(self, label: str | None) -> None:
        """Put ``label`` in the gripper (or empty it) without taking it from a place: the
        world as someone sets it (a parameter), not as the gripper changes it."""
        if label is not None and label not in self.spec.objects:
            raise WorldError(
                f"unknown object {label!r}; the catalogue has: {', '.join(self.spec.objects)}"
            )
        with self._lock:
            self._held = label

    def take(self, place: str, label: str) -> None:
        """The gripper takes one ``label`` from ``place``: it leaves the place and is held."""
        with self._lock:
            if self._held is not None:
                raise WorldError(f"the gripper already holds the {self._held}")
            if label not in self._objects.get(place, []):
                raise WorldError(f"there is no {label} at {place}")
            self._objects[place].remove(label)
            self._held = label
            self.version += 1

    def put(self, place: str) -> str:
        """The gripper puts what it holds down at ``place``; returns its label."""
        with self._lock:
            label = self._held
            if label is None:
                raise WorldError("the gripper holds nothing")
            if place not in self._objects:
                raise WorldError(f"unknown place {place!r}")
            if len(self._objects[place]) >= MAX_OBJECTS_PER_PLACE:
                raise WorldError(f"{place} is full ({MAX_OBJECTS_PER_PLACE} objects)")
            self._objects[place].append(label)
            self._held = None
            self.version += 1
            return label

    def look(self, label: str) -> ObjectLook:
        return self.spec.objects[label]
