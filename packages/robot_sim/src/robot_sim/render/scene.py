"""The office as a MuJoCo scene (MJCF): walls from the occupancy grid, room floors, furniture
from the floor plan, doors, and every object of the world on its place's furniture.

Walls are the map's occupied cells that are not furniture or a door, merged into boxes row
run by row run, so any map_server map gives its walls. Each object is one or a few primitive
geoms named ``obj<N>_<part>``; :class:`SceneSpec` maps them back to the object (label, place).
"""

from __future__ import annotations

import math
import re
import zlib
from dataclasses import dataclass, field
from xml.sax.saxutils import quoteattr

import numpy as np

from robot_sim.floor.draw import door_box
from robot_sim.floor.floor import Floor
from robot_sim.floor.grid import Grid, Mask
from robot_sim.floor.plan import Furniture
from robot_sim.world import RGB, ObjectLook, World

WALL_HEIGHT = 2.4
WALL_RGB: RGB = (226, 222, 212)
DOOR_RGB: RGB = (122, 84, 52)
SLOT_ACROSS = (0.3, 0.0, -0.3)
"""Lateral offsets of a top's three slots (left to right as the robot faces it)."""
SLOT_DEPTH = (0.16, 0.42)
"""How far behind the top's near edge its two rows of slots are."""
_NAME = re.compile(r'name="([^"]+)"')
FLOOR_AHEAD_M = 0.9
"""Objects of a place without furniture stand on the floor this far ahead of the place."""


@dataclass(frozen=True)
class PlacedObject:
    index: int
    label: str
    place: str
    geoms: tuple[str, ...]


@dataclass
class SceneSpec:
    xml: str
    objects: list[PlacedObject] = field(default_factory=list)
    doors: dict[str, str] = field(default_factory=dict)
    """Door name → its geom name (moved below the floor while the door is open)."""


def _rgba(rgb: RGB, alpha: float = 1.0) -> str:
    return f"{rgb[0] / 255:.3f} {rgb[1] / 255:.3f} {rgb[2] / 255:.3f} {alpha:g}"


def _box(name: str, centre: tuple[float, float, float], half: tuple[float, float, float],
         rgb: RGB, yaw: float = 0.0) -> str:  # fmt: skip
    x, y, z = centre
    return (
        f"<geom name={quoteattr(name)} type='box' pos='{x:.4f} {y:.4f} {z:.4f}' "
        f"size='{half[0]:.4f} {half[1]:.4f} {half[2]:.4f}' euler='0 0 {yaw:.4f}' "
        f"rgba='{_rgba(rgb)}'/>"
    )


def _cylinder(name: str, centre: tuple[float, float, float], radius: float, half: float,
              rgb: RGB) -> str:  # fmt: skip
    x, y, z = centre
    return (
        f"<geom name={quoteattr(name)} type='cylinder' pos='{x:.4f} {y:.4f} {z:.4f}' "
        f"size='{radius:.4f} {half:.4f}' rgba='{_rgba(rgb)}'/>"
    )


def wall_boxes(grid: Grid, walls: Mask) -> list[tuple[float, float, float, float]]:
    """``walls`` as few axis-aligned boxes (x0, y0, x1, y1): runs of each row, merged with
    identical runs of the rows above."""
    boxes: list[tuple[float, float, float, float]] = []
    open_runs: dict[tuple[int, int], int] = {}  # (c0, c1) → first row
    for row in range(grid.height + 1):
        runs: set[tuple[int, int]] = set()
        if row < grid.height:
            line = np.concatenate(([False], walls[row], [False]))
            edges = np.flatnonzero(line[1:] != line[:-1])
            runs = {(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2], strict=True)}
        for run in list(open_runs):
            if run not in runs:
                first = open_runs.pop(run)
                x0, y0 = (
                    grid.origin[0] + run[0] * grid.resolution,
                    grid.origin[1] + first * grid.resolution,
                )
                x1, y1 = (
                    grid.origin[0] + run[1] * grid.resolution,
                    grid.origin[1] + row * grid.resolution,
                )
                boxes.append((x0, y0, x1, y1))
        for run in runs:
            open_runs.setdefault(run, row)
    return boxes


def slot_positions(world: World, place: str) -> list[tuple[float, float, float, float]]:
    """(x, y, z of the surface, yaw facing the robot) of the place's six slots."""
    pose = world.map.locations[place].pose()
    c, s = math.cos(pose.theta), math.sin(pose.theta)
    top = world.floor.plan.furniture_of(place)
    near, far, height = FLOOR_AHEAD_M - 0.2, FLOOR_AHEAD_M + 0.4, 0.0
    if top is not None:
        near, far = _extent_ahead(top, pose.x, pose.y, c, s)
        height = top.height
    slots = []
    for depth in SLOT_DEPTH:
        ahead = min(near + depth, (near + far) / 2.0 if far - near < 2 * depth else far - 0.12)
        for across in SLOT_ACROSS:
            slots.append(
                (
                    pose.x + c * ahead - s * across,
                    pose.y + s * ahead + c * across,
                    height,
                    pose.theta,
                )
            )
    return slots


def _extent_ahead(top: Furniture, x: float, y: float, c: float, s: float) -> tuple[float, float]:
    """Where the robot's line of sight enters and leaves the furniture's box (metres ahead)."""
    x0, y0, x1, y1 = top.box
    ahead = [(cx - x) * c + (cy - y) * s for cx in (x0, x1) for cy in (y0, y1)]
    return max(0.0, min(ahead)), max(ahead)


def _darker(rgb: RGB, factor: float = 0.7) -> RGB:
    return (int(rgb[0] * factor), int(rgb[1] * factor), int(rgb[2] * factor))


def _object_geoms(
    prefix: str, look: ObjectLook, at: tuple[float, float, float, float], seed: int
) -> list[str]:
    """The object's primitives standing at ``at`` (x, y, surface z, yaw), turned a little."""
    x, y, z, facing = at
    yaw = facing + float(np.random.default_rng(seed).uniform(-0.5, 0.5))
    rgb = look.colour
    c, s = math.cos(yaw), math.sin(yaw)
    shape = look.shape
    if shape == "mug":
        handle = (x + 0.058 * s, y - 0.058 * c, z + 0.055)
        return [
            _cylinder(f"{prefix}_body", (x, y, z + 0.055), 0.045, 0.055, rgb),
            _box(f"{prefix}_handle", handle, (0.012, 0.012, 0.03), rgb, yaw),
        ]
    if shape == "bottle":
        return [
            _cylinder(f"{prefix}_body", (x, y, z + 0.09), 0.035, 0.09, rgb),
            _cylinder(f"{prefix}_neck", (x, y, z + 0.215), 0.015, 0.035, rgb),
        ]
    if shape == "parcel":
        return [_box(f"{prefix}_body", (x, y, z + 0.07), (0.11, 0.15, 0.07), rgb, yaw)]
    if shape == "box":
        return [_box(f"{prefix}_body", (x, y, z + 0.1), (0.1, 0.1, 0.1), rgb, yaw)]
    if shape == "folder":
        return [_box(f"{prefix}_body", (x, y, z + 0.015), (0.11, 0.15, 0.015), rgb, yaw)]
    if shape == "plate":
        return [_cylinder(f"{prefix}_body", (x, y, z + 0.008), 0.11, 0.008, rgb)]
    # scissors: two blades crossing and two finger loops
    blade = (0.012, 0.1, 0.006)
    loop1 = (x - 0.04 * c + 0.09 * s, y - 0.04 * s - 0.09 * c, z + 0.008)
    loop2 = (x + 0.04 * c + 0.09 * s, y + 0.04 * s - 0.09 * c, z + 0.008)
    return [
        _box(f"{prefix}_blade1", (x, y, z + 0.006), blade, rgb, yaw + 0.35),
        _box(f"{prefix}_blade2", (x, y, z + 0.006), blade, rgb, yaw - 0.35),
        _cylinder(f"{prefix}_loop1", loop1, 0.03, 0.008, _darker(rgb)),
        _cylinder(f"{prefix}_loop2", loop2, 0.03, 0.008, _darker(rgb)),
    ]


def _slab(name: str, box: tuple[float, float, float, float], z0: float, z1: float, rgb: RGB) -> str:
    """A box geom over the floor rectangle ``box`` from height ``z0`` to ``z1``."""
    x0, y0, x1, y1 = box
    centre = ((x0 + x1) / 2, (y0 + y1) / 2, (z0 + z1) / 2)
    return _box(name, centre, ((x1 - x0) / 2, (y1 - y0) / 2, (z1 - z0) / 2), rgb)


def build_scene(world: World, width: int, height: int, fovy_deg: float) -> SceneSpec:
    """The MJCF of the world as it is now (objects, doors as geoms to show or hide)."""
    floor: Floor = world.floor
    grid = floor.grid
    furniture_mask = np.zeros(grid.cells.shape, bool)
    for item in floor.plan.furniture.values():
        furniture_mask |= grid.box_mask(item.box)
    door_mask = np.zeros(grid.cells.shape, bool)
    for cells in floor.door_cells.values():
        door_mask |= cells
    geoms: list[str] = []
    walls = grid.occupied & ~furniture_mask & ~door_mask
    for i, box in enumerate(wall_boxes(grid, walls)):
        geoms.append(_slab(f"wall{i}", box, 0.0, WALL_HEIGHT, WALL_RGB))
    for name, room in floor.plan.rooms.items():
        geoms.append(_slab(f"room_{name}", room.box, 0.0, 0.002, room.floor))
    for name, item in floor.plan.furniture.items():
        top = world.place(item.place).surface if item.place else item.colour
        body = _darker(item.colour, 0.8)
        x0, y0, x1, y1 = item.box
        overhang = (x0 - 0.01, y0 - 0.01, x1 + 0.01, y1 + 0.01)
        geoms.append(_slab(f"furniture_{name}", item.box, 0.0, item.height - 0.03, body))
        geoms.append(_slab(f"top_{name}", overhang, item.height - 0.03, item.height, top))
    spec = SceneSpec("")
    for name, door in floor.plan.doors.items():
        spec.doors[name] = f"door_{name}"
        panel = door_box(floor.plan, door.segment)
        geoms.append(_slab(f"door_{name}", panel, 0.0, 2.0, DOOR_RGB))
    for place in world.places:
        slots = slot_positions(world, place)
        for slot, label in enumerate(world.objects_at(place)):
            index = len(spec.objects) + 1
            seed = zlib.crc32(f"{place}/{slot}/{label}".encode())
            parts = _object_geoms(f"obj{index}", world.look(label), slots[slot], seed)
            geoms.extend(parts)
            names = tuple(_NAME.search(part).group(1) for part in parts)  # type: ignore[union-attr]
            spec.objects.append(PlacedObject(index, label, place, names))
    lights = _lights(floor)
    spec.xml = f"""<mujoco model="office">
  <visual>
    <global offwidth="{width}" offheight="{height}" fovy="{fovy_deg:g}"/>
    <headlight ambient="0.35 0.35 0.35" diffuse="0.25 0.25 0.25" specular="0 0 0"/>
    <quality shadowsize="0"/>
    <map znear="0.02" zfar="60"/>
  </visual>
  <worldbody>
    <geom name="ground" type="plane" size="60 60 0.1" rgba="0.35 0.35 0.36 1"/>
    {lights}
    <camera name="robot" pos="0 0 1.2" fovy="{fovy_deg:g}"/>
    {chr(10).join("    " + g for g in geoms)}
  </worldbody>
</mujoco>"""
    return spec


def _lights(floor: Floor) -> str:
    """A ceiling light over every room, no shadows (cheap on a software renderer)."""
    lights = []
    for name, room in floor.plan.rooms.items():
        x0, y0, x1, y1 = room.box
        lights.append(
            f"<light name='light_{name}' pos='{(x0 + x1) / 2:.2f} {(y0 + y1) / 2:.2f} 2.3' "
            "dir='0 0 -1' directional='false' castshadow='false' diffuse='0.45 0.45 0.43' "
            "attenuation='1 0.05 0.01'/>"
        )
    return "\n    ".join(lights)
