"""The site map file: named locations, cruise speed and scripted failures (YAML, validated).

One format for every reader: the navigation server drives to these places, robot-sim stands
them in its world; both load the same file with :func:`load_map`.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any, Literal

import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator

from robot_site_map.pose import Pose

_NAME = re.compile(r"^[a-z0-9_]+$")


class MapError(ValueError):
    """The map file is missing, is not YAML, or does not describe a valid map."""


def normalize_name(name: str) -> str:
    """How location names are compared: case-insensitive, spaces and dashes as underscores."""
    return re.sub(r"[\s\-]+", "_", name.strip().lower())


class Location(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)

    x: float
    y: float
    theta: float = 0.0
    description: str = ""
    aliases: list[str] = Field(default_factory=list)

    def pose(self) -> Pose:
        return Pose(self.x, self.y, self.theta)


class FailureSpec(BaseModel):
    """A failure the simulated base produces on the way to ``location`` (e.g. a closed door)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    location: str
    error_code: str = Field(pattern=r"^[A-Z][A-Z0-9_]*$")
    message: str = Field(min_length=1)
    recoverable: bool = True
    suggestions: list[str] = Field(default_factory=list)
    mode: Literal["once", "always"] = "once"
    at_fraction: float = Field(default=0.85, gt=0.0, lt=1.0)

    @field_validator("location")
    @classmethod
    def _normalize_location(cls, value: str) -> str:
        return normalize_name(value)


class NavMap(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)

    name: str = "map"
    frame: str = "map"
    speed_mps: float = Field(default=0.8, gt=0.0, le=5.0)
    start: str
    locations: dict[str, Location] = Field(min_length=1)
    failures: list[FailureSpec] = Field(default_factory=list)

    @field_validator("start")
    @classmethod
    def _normalize_start(cls, value: str) -> str:
        return normalize_name(value)

    @field_validator("locations")
    @classmethod
    def _check_names(cls, value: dict[str, Location]) -> dict[str, Location]:
        for name in value:
            if not _NAME.match(name):
                raise ValueError(
                    f"location name {name!r} must be lower-case letters, digits and underscores"
                )
        return value

    @model_validator(mode="after")
    def _check_references(self) -> NavMap:
        if self.start not in self.locations:
            raise ValueError(f"start {self.start!r} is not one of the locations")
        seen: dict[str, str] = {}
        for name, location in self.locations.items():
            for alias in [name, *(normalize_name(a) for a in location.aliases)]:
                if alias in seen and seen[alias] != name:
                    raise ValueError(f"alias {alias!r} names both {seen[alias]!r} and {name!r}")
                seen[alias] = name
        for failure in self.failures:
            if failure.location not in self.locations:
                raise ValueError(
                    f"failure {failure.error_code} refers to unknown location {failure.location!r}"
                )
        return self

    def resolve(self, name: str) -> str | None:
        """The canonical location name for ``name`` or one of its aliases, else None."""
        wanted = normalize_name(name)
        if wanted in self.locations:
            return wanted
        for canonical, location in self.locations.items():
            if wanted in (normalize_name(a) for a in location.aliases):
                return canonical
        return None

    def without_failures(self) -> NavMap:
        return self.model_copy(update={"failures": []})


def parse_map(data: Any, source: str = "<map>") -> NavMap:
    """Validate already-parsed YAML data; errors name the source and every bad field."""
    if not isinstance(data, dict):
        raise MapError(f"{source}: the map must be a YAML mapping, got {type(data).__name__}")
    try:
        return NavMap.model_validate(data)
    except ValidationError as exc:
        problems = "; ".join(
            f"{'.'.join(str(p) for p in err['loc']) or '<root>'}: {err['msg']}"
            for err in exc.errors()
        )
        raise MapError(f"{source}: invalid map: {problems}") from exc


def load_map(path: Path) -> NavMap:
    """Read and validate a map file; every problem is a MapError naming the file."""
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError as exc:
        raise MapError(f"map file not found: {path}") from exc
    except OSError as exc:
        raise MapError(f"cannot read map file {path}: {exc}") from exc
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise MapError(f"{path}: not valid YAML: {exc}") from exc
    return parse_map(data, str(path))
