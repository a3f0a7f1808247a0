"""The floor plan: a declarative description of the office (rooms walled round, openings and
doors cut into the walls, furniture), validated at load. ``draw.py`` turns it into
map_server's map; robot-sim reads doors, furniture and rooms from it at run time.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator

RGB = tuple[int, int, int]
Box = tuple[float, float, float, float]
"""x0, y0, x1, y1 in metres, x0 < x1 and y0 < y1."""
Segment = tuple[float, float, float, float]
"""x0, y0, x1, y1 in metres, horizontal or vertical."""


class FloorError(ValueError):
    """The floor plan or its map is missing, unreadable or invalid."""


def _box(value: Box) -> Box:
    x0, y0, x1, y1 = value
    if not (x0 < x1 and y0 < y1):
        raise ValueError(f"box {list(value)} must be [x0, y0, x1, y1] with x0 < x1, y0 < y1")
    return value


def _segment(value: Segment) -> Segment:
    x0, y0, x1, y1 = value
    if (x0 != x1) == (y0 != y1):
        raise ValueError(f"segment {list(value)} must be horizontal or vertical, and not a point")
    return value


class Room(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)

    label: str = Field(min_length=1)
    box: Box
    floor: RGB = (190, 184, 172)
    """The floor's colour in the camera's view."""

    @field_validator("box")
    @classmethod
    def _check_box(cls, value: Box) -> Box:
        return _box(value)


class Door(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)

    label: str = Field(min_length=1)
    """How people name it ("mailroom west door"); never shown as the id."""
    segment: Segment

    @field_validator("segment")
    @classmethod
    def _check_segment(cls, value: Segment) -> Segment:
        return _segment(value)

    @property
    def centre(self) -> tuple[float, float]:
        x0, y0, x1, y1 = self.segment
        return (x0 + x1) / 2.0, (y0 + y1) / 2.0


class Furniture(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)

    label: str = Field(min_length=1)
    box: Box
    height: float = Field(gt=0.0, le=3.0)
    colour: RGB
    place: str | None = None
    """A location of the navigation map: that place's objects stand on this top."""

    @field_validator("box")
    @classmethod
    def _check_box(cls, value: Box) -> Box:
        return _box(value)


class FloorPlan(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)

    map: str = Field(min_length=1)
    """The map_server yaml this plan is drawn into (relative to the plan)."""
    image: str = Field(min_length=1)
    resolution: float = Field(gt=0.0, le=1.0)
    origin: tuple[float, float]
    size: tuple[float, float]
    wall_thickness: float = Field(default=0.15, gt=0.0, le=1.0)
    rooms: dict[str, Room] = Field(min_length=1)
    openings: list[Segment] = Field(default_factory=list)
    doors: dict[str, Door] = Field(default_factory=dict)
    furniture: dict[str, Furniture] = Field(default_factory=dict)

    @field_validator("openings")
    @classmethod
    def _openings(cls, value: list[Segment]) -> list[Segment]:
        return [_segment(v) for v in value]

    def furniture_of(self, place: str) -> Furniture | None:
        return next((f for f in self.furniture.values() if f.place == place), None)

    def room_at(self, x: float, y: float) -> Room | None:
        """The room whose box holds (x, y) (the first listed where boxes touch)."""
        for room in self.rooms.values():
            x0, y0, x1, y1 = room.box
            if x0 <= x <= x1 and y0 <= y <= y1:
                return room
        return None


def _problems(exc: ValidationError) -> str:
    return "; ".join(
        f"{'.'.join(str(p) for p in err['loc']) or '<root>'}: {err['msg']}" for err in exc.errors()
    )


def load_plan(path: Path) -> FloorPlan:
    """Read and validate a floor plan; every problem is a FloorError naming the file."""
    try:
        data: Any = yaml.safe_load(path.read_text(encoding="utf-8"))
    except FileNotFoundError as exc:
        raise FloorError(f"floor plan not found: {path}") from exc
    except (OSError, yaml.YAMLError) as exc:
        raise FloorError(f"cannot read floor plan {path}: {exc}") from exc
    if not isinstance(data, dict):
        raise FloorError(f"{path}: the floor plan must be a YAML mapping")
    try:
        return FloorPlan.model_validate(data)
    except ValidationError as exc:
        raise FloorError(f"{path}: invalid floor plan: {_problems(exc)}") from exc
