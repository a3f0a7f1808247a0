"""The robot's camera: renders the office from the robot's pose (MuJoCo), annotates the frame
from the renderer's segmentation and saves both in the scenes folder before the frame is
published (the offline grounder's contract, ``store.py``). A frame is rendered again only when
the pose or the world changed; otherwise the last one is published again."""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
import structlog

from robot_sim.render.annotate import annotate_view, describe
from robot_sim.render.renderer import MujocoRenderer
from robot_sim.store import SceneStore, StoredFrame
from robot_sim.world import World
from robot_site_map import Pose

logger = structlog.get_logger(__name__)


@dataclass(frozen=True)
class Shot:
    frame: StoredFrame
    depth: npt.NDArray[np.float32] | None
    rendered: bool
    """False: the same view as the previous shot, nothing was rendered."""


class Camera:
    def __init__(
        self,
        world: World,
        store: SceneStore,
        renderer: MujocoRenderer,
        place_radius_m: float = 0.5,
        moving_scale: float = 1.0,
    ) -> None:
        self.world = world
        self.store = store
        self.renderer = renderer
        self.place_radius_m = place_radius_m
        self.moving_scale = moving_scale
        """Internal render scale while the robot moves (a standing robot's frame is full)."""
        self._lock = threading.Lock()
        self._last: tuple[Any, Shot] | None = None

    def place_at(self, pose: Pose) -> str | None:
        """The place within ``place_radius_m`` of ``pose``, if any."""
        name, location = min(
            self.world.map.locations.items(), key=lambda item: item[1].pose().distance_to(pose)
        )
        return name if location.pose().distance_to(pose) <= self.place_radius_m else None

    def shot(self, pose: Pose, depth: bool = False, moving: bool = False) -> Shot:
        """The frame from ``pose`` as the world is now (saved before it is returned)."""
        scale = self.moving_scale if moving else 1.0
        key = (
            round(pose.x, 3), round(pose.y, 3), round(pose.theta, 3),
            self.world.version, self.world.closed_doors(), scale,
        )  # fmt: skip
        with self._lock:
            if self._last is not None and self._last[0] == key:
                shot = self._last[1]
                if not depth or shot.depth is not None:
                    self.store.touch(shot.frame.name)
                    return Shot(shot.frame, shot.depth, rendered=False)
            started = time.perf_counter()
            view = self.renderer.render(pose, depth=depth, scale=scale)
            place = self.place_at(pose)
            found = annotate_view(view)
            doc = {
                "place": place,
                "pose": pose.as_dict(),
                "description": describe(self._where(pose, place), [a["label"] for a in found]),
                "annotations": found,
            }
            frame = self.store.save(place or self._room_key(pose), view.rgb, doc)
            shot = Shot(frame, view.depth, rendered=True)
            self._last = (key, shot)
            logger.debug(
                "camera_rendered",
                frame=frame.name,
                objects=list(frame.labels),
                duration_ms=round(1000 * (time.perf_counter() - started), 1),
            )
            return shot

    def _where(self, pose: Pose, place: str | None) -> str:
        if place is not None:
            described = self.world.place(place).description
            if described:
                return described
        room = self.world.floor.plan.room_at(pose.x, pose.y)
        label = room.label if room is not None else "the office"
        return f"{label[:1].upper()}{label[1:]}."

    def _room_key(self, pose: Pose) -> str:
        for name, room in self.world.floor.plan.rooms.items():
            x0, y0, x1, y1 = room.box
            if x0 <= pose.x <= x1 and y0 <= pose.y <= y1:
                return name
        return "view"
