"""MapView: the port through which the navigation server reads the robot's map, costmap and
current plan. ``rclpy_view.py`` subscribes Nav2's standard topics; ``NoMapView`` stands for a
base that publishes none (the in-process simulated base); tests use ``fake.py``."""

from __future__ import annotations

import abc
from dataclasses import dataclass


@dataclass(frozen=True)
class GridSnapshot:
    """A ``nav_msgs/OccupancyGrid``: ``cells`` row-major from the lower-left cell, int8
    (0 free … 100 occupied, −1 unknown)."""

    frame: str
    resolution: float
    origin: tuple[float, float]
    width: int
    height: int
    cells: bytes
    received_at: float
    """``time.monotonic()`` when it arrived."""


@dataclass(frozen=True)
class PathSnapshot:
    """A ``nav_msgs/Path`` as (x, y) points."""

    frame: str
    points: tuple[tuple[float, float], ...]
    received_at: float


class MapView(abc.ABC):
    @abc.abstractmethod
    def map(self) -> GridSnapshot | None:
        """The latest ``/map`` (None before the first message)."""

    @abc.abstractmethod
    def costmap(self) -> GridSnapshot | None:
        """The latest global costmap (None when none is published)."""

    @abc.abstractmethod
    def plan(self) -> PathSnapshot | None:
        """The latest global plan (None before the first message)."""


class NoMapView(MapView):
    """A base that publishes no map (the in-process simulated base): the UI draws the named
    places alone."""

    def map(self) -> GridSnapshot | None:
        return None

    def costmap(self) -> GridSnapshot | None:
        return None

    def plan(self) -> PathSnapshot | None:
        return None
