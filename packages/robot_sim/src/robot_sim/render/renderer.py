"""Offscreen rendering of the office with MuJoCo (CPU through OSMesa unless ``MUJOCO_GL`` says
otherwise): an RGB image, the segmentation (which object each pixel shows) and, when asked,
depth, from the robot camera's pose.

The camera stands on the robot at ``CAMERA_HEIGHT_M``, looks the way the robot faces, pitched
down ``CAMERA_PITCH_DEG`` so a table top a metre ahead is in the middle of the frame. The model
is rebuilt when the world's objects changed; doors are moved in or out of their frames.

An OpenGL context belongs to one thread (OSMesa crashes when another thread makes it current),
so every render runs on the renderer's own thread; callers on any thread wait for it.

``scale`` < 1 renders at a lower internal resolution and scales the image up (linear) and the
segmentation and depth (nearest) to 640×480: the software rasteriser's cost follows the pixel
count, so the moving robot's frames (a new view every frame) cost a quarter at ``scale=0.5``.
"""

from __future__ import annotations

import math
import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np
import numpy.typing as npt

from robot_sim.render.scene import PlacedObject, SceneSpec, build_scene
from robot_sim.world import World
from robot_site_map import Pose

os.environ.setdefault("MUJOCO_GL", "osmesa")
os.environ.setdefault("PYOPENGL_PLATFORM", os.environ["MUJOCO_GL"])

import mujoco

WIDTH, HEIGHT = 640, 480
FOVY_DEG = 58.0
CAMERA_HEIGHT_M = 1.2
CAMERA_PITCH_DEG = 24.0
_GEOM = int(mujoco.mjtObj.mjOBJ_GEOM)

Pixels = npt.NDArray[np.uint8]


@dataclass(frozen=True)
class RenderedView:
    rgb: Pixels
    """(HEIGHT, WIDTH, 3) uint8."""
    instances: npt.NDArray[np.int32]
    """(HEIGHT, WIDTH): the object index (``PlacedObject.index``) each pixel shows, 0 none."""
    objects: list[PlacedObject]
    depth: npt.NDArray[np.float32] | None = None
    """Metres along the optical axis, when asked for."""


def camera_matrix(
    width: int = WIDTH, height: int = HEIGHT, fovy_deg: float = FOVY_DEG
) -> tuple[float, float, float, float]:
    """fx, fy, cx, cy of the pinhole camera (square pixels)."""
    fy = (height / 2.0) / math.tan(math.radians(fovy_deg) / 2.0)
    return fy, fy, width / 2.0, height / 2.0


def camera_quaternion(yaw: float, pitch_deg: float = CAMERA_PITCH_DEG) -> npt.NDArray[np.float64]:
    """MuJoCo's camera looks along its −z with +y up: the frame for a robot facing ``yaw``."""
    pitch = math.radians(pitch_deg)
    forward = np.array(
        [math.cos(yaw) * math.cos(pitch), math.sin(yaw) * math.cos(pitch), -math.sin(pitch)]
    )
    up = np.array(
        [math.cos(yaw) * math.sin(pitch), math.sin(yaw) * math.sin(pitch), math.cos(pitch)]
    )
    right = np.cross(forward, up)
    matrix = np.column_stack([right, up, -forward]).reshape(-1)
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, matrix)
    return quat


class MujocoRenderer:
    """Renders ``world`` from robot poses; thread-safe (one GL context on its own thread)."""

    def __init__(self, world: World, width: int = WIDTH, height: int = HEIGHT) -> None:
        self.world = world
        self.width, self.height = width, height
        self._thread = ThreadPoolExecutor(max_workers=1, thread_name_prefix="mujoco-render")
        self._built_for: int | None = None
        self._spec: SceneSpec | None = None
        self._model: Any = None
        self._data: Any = None
        self._renderer: Any = None
        self._scaled: dict[float, Any] = {}
        """Renderers at lower internal resolutions, by scale."""
        self._geom_object: npt.NDArray[np.int32] = np.zeros(1, np.int32)
        self._doors_shown: frozenset[str] | None = None

    def close(self) -> None:
        """Release the GL context (idempotent)."""
        try:
            self._thread.submit(self._release).result()
        except RuntimeError:  # closed already
            return
        self._thread.shutdown()

    def _release(self) -> None:
        for renderer in [self._renderer, *self._scaled.values()]:
            if renderer is not None:
                renderer.close()
        self._renderer, self._scaled = None, {}

    def render(self, pose: Pose, depth: bool = False, scale: float = 1.0) -> RenderedView:
        if not 0.1 <= scale <= 1.0:
            raise ValueError("scale must be within 0.1 .. 1")
        return self._thread.submit(self._render, pose, depth, scale).result()

    def _render(self, pose: Pose, depth: bool, scale: float) -> RenderedView:
        self._rebuild_if_changed()
        assert self._spec is not None
        self._place_camera(pose)
        self._show_doors(self.world.closed_doors())
        mujoco.mj_kinematics(self._model, self._data)
        mujoco.mj_camlight(self._model, self._data)
        renderer = self._renderer if scale >= 1.0 else self._at_scale(scale)
        renderer.update_scene(self._data, camera="robot")
        rgb = np.array(renderer.render(), np.uint8)
        renderer.enable_segmentation_rendering()
        try:
            renderer.update_scene(self._data, camera="robot")
            seg = renderer.render()
        finally:
            renderer.disable_segmentation_rendering()
        ids, types = seg[..., 0], seg[..., 1]
        geoms = np.where((types == _GEOM) & (ids >= 0), ids, -1)
        instances = np.where(geoms >= 0, self._geom_object[np.maximum(geoms, 0)], 0)
        metres = None
        if depth:
            renderer.enable_depth_rendering()
            try:
                renderer.update_scene(self._data, camera="robot")
                metres = np.array(renderer.render(), np.float32)
            finally:
                renderer.disable_depth_rendering()
        instances = instances.astype(np.int32)
        if scale < 1.0:
            size = (self.width, self.height)
            rgb = np.asarray(cv2.resize(rgb, size, interpolation=cv2.INTER_LINEAR), np.uint8)
            instances = np.asarray(
                cv2.resize(instances, size, interpolation=cv2.INTER_NEAREST), np.int32
            )
            if metres is not None:
                metres = np.asarray(
                    cv2.resize(metres, size, interpolation=cv2.INTER_NEAREST), np.float32
                )
        return RenderedView(rgb, instances, list(self._spec.objects), metres)

    def _at_scale(self, scale: float) -> Any:
        renderer = self._scaled.get(scale)
        if renderer is None:
            height, width = round(self.height * scale), round(self.width * scale)
            renderer = mujoco.Renderer(self._model, height, width)
            self._scaled[scale] = renderer
        return renderer

    def _rebuild_if_changed(self) -> None:
        version = self.world.version
        if (
            self._built_for is not None
            and self._built_for == version
            and self._renderer is not None
        ):
            return
        self._built_for = version
        spec = build_scene(self.world, self.width, self.height, FOVY_DEG)
        model = mujoco.MjModel.from_xml_string(spec.xml)
        self._release()
        self._spec, self._model, self._data = spec, model, mujoco.MjData(model)
        self._renderer = mujoco.Renderer(model, self.height, self.width)
        lookup = np.zeros(model.ngeom, np.int32)
        for placed in spec.objects:
            for name in placed.geoms:
                lookup[model.geom(name).id] = placed.index
        self._geom_object = lookup
        self._doors_shown = None

    def _place_camera(self, pose: Pose) -> None:
        camera = self._model.camera("robot").id
        self._model.cam_pos[camera] = (pose.x, pose.y, CAMERA_HEIGHT_M)
        self._model.cam_quat[camera] = camera_quaternion(pose.theta)

    def _show_doors(self, closed: frozenset[str]) -> None:
        if closed == self._doors_shown:
            return
        assert self._spec is not None
        for door, geom in self._spec.doors.items():
            body = self._model.geom(geom)
            body.pos[2] = 1.0 if door in closed else -5.0  # an open door is below the floor
        self._doors_shown = closed
