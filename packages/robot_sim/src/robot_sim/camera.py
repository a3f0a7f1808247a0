"""Which scene the camera shows: the place the robot stands at, else the corridor."""

from __future__ import annotations

import threading

from robot_mcp_navigation.motion.base import Pose
from robot_sim.scenes import CORRIDOR, Scene, render_corridor, render_place
from robot_sim.store import SceneStore, StoredFrame
from robot_sim.world import World


class Camera:
    """Renders (once per distinct content) and saves the frame for where the robot is."""

    def __init__(self, world: World, store: SceneStore, place_radius_m: float = 0.5) -> None:
        self.world = world
        self.store = store
        self.place_radius_m = place_radius_m
        self._lock = threading.Lock()
        self._rendered: dict[tuple[str, tuple[str, ...]], StoredFrame] = {}

    def view_of(self, pose: Pose, driving: bool) -> str:
        """The place within ``place_radius_m`` of a standing robot, else ``corridor``."""
        if driving:
            return CORRIDOR
        best = min(
            self.world.map.locations.items(), key=lambda item: item[1].pose().distance_to(pose)
        )
        name, location = best
        return name if location.pose().distance_to(pose) <= self.place_radius_m else CORRIDOR

    def frame(self, view: str) -> StoredFrame:
        """The saved frame for ``view`` with the world's current contents."""
        contents = () if view == CORRIDOR else self.world.objects_at(view)
        key = (view, contents)
        with self._lock:
            known = self._rendered.get(key)
        if known is not None:
            return known
        stored = self.store.save(self.scene(view))
        with self._lock:
            self._rendered[key] = stored
        return stored

    def scene(self, view: str) -> Scene:
        if view == CORRIDOR:
            corridor = self.world.spec.corridor
            return render_corridor(corridor.surface, corridor.description)
        place = self.world.place(view)
        labels = self.world.objects_at(view)
        return render_place(
            view,
            place.surface,
            place.description,
            [(label, self.world.look(label)) for label in labels],
        )

    def prepare(self) -> list[StoredFrame]:
        """Save every place's current scene and the corridor (the grounder's start-up folder)."""
        return [self.frame(view) for view in [*self.world.places, CORRIDOR]]
