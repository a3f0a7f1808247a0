"""RclpyMapView: the MapView port over rclpy, on the process's RosBridge. Subscribes what a
robot running Nav2 publishes: ``/map`` (map_server: reliable, transient local), the global
costmap (``/global_costmap/costmap``, the same QoS) and ``/plan`` (the planner server).

Imports rclpy and nav_msgs: only the composition root imports it, with ``NAV_MOTION=nav2``.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np
from nav_msgs.msg import OccupancyGrid, Path
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

from robot_mcp_navigation.mapview.base import GridSnapshot, MapView, PathSnapshot
from robot_ros_bridge import RosBridge

LATCHED = QoSProfile(
    depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL
)
PLAN_QOS = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE)


def grid_of(msg: Any, received_at: float) -> GridSnapshot:
    info = msg.info
    return GridSnapshot(
        frame=str(msg.header.frame_id),
        resolution=float(info.resolution),
        origin=(float(info.origin.position.x), float(info.origin.position.y)),
        width=int(info.width),
        height=int(info.height),
        cells=np.asarray(msg.data, np.int8).tobytes(),
        received_at=received_at,
    )


def path_of(msg: Any, received_at: float) -> PathSnapshot:
    points = tuple((float(p.pose.position.x), float(p.pose.position.y)) for p in msg.poses)
    return PathSnapshot(str(msg.header.frame_id), points, received_at)


class RclpyMapView(MapView):
    def __init__(
        self, bridge: RosBridge, map_topic: str, costmap_topic: str, plan_topic: str
    ) -> None:
        self._map: GridSnapshot | None = None
        self._costmap: GridSnapshot | None = None
        self._plan: PathSnapshot | None = None
        bridge.create_subscription(OccupancyGrid, map_topic, self._on_map, LATCHED)
        bridge.create_subscription(OccupancyGrid, costmap_topic, self._on_costmap, LATCHED)
        bridge.create_subscription(Path, plan_topic, self._on_plan, PLAN_QOS)

    # executor thread: each callback replaces one reference
    def _on_map(self, msg: Any) -> None:
        self._map = grid_of(msg, time.monotonic())

    def _on_costmap(self, msg: Any) -> None:
        self._costmap = grid_of(msg, time.monotonic())

    def _on_plan(self, msg: Any) -> None:
        self._plan = path_of(msg, time.monotonic())

    def map(self) -> GridSnapshot | None:
        return self._map

    def costmap(self) -> GridSnapshot | None:
        return self._costmap

    def plan(self) -> PathSnapshot | None:
        return self._plan
