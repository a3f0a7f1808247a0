"""FakeMapView: the MapView port in memory; the test publishes what the topics would carry."""

from __future__ import annotations

import time

from robot_mcp_navigation.mapview.base import GridSnapshot, MapView, PathSnapshot


class FakeMapView(MapView):
    def __init__(self) -> None:
        self._map: GridSnapshot | None = None
        self._costmap: GridSnapshot | None = None
        self._plan: PathSnapshot | None = None

    def publish_map(self, snapshot: GridSnapshot) -> None:
        self._map = snapshot

    def publish_costmap(self, snapshot: GridSnapshot) -> None:
        self._costmap = snapshot

    def publish_plan(self, points: list[tuple[float, float]], frame: str = "map") -> None:
        self._plan = PathSnapshot(frame, tuple(points), time.monotonic())

    def map(self) -> GridSnapshot | None:
        return self._map

    def costmap(self) -> GridSnapshot | None:
        return self._costmap

    def plan(self) -> PathSnapshot | None:
        return self._plan
