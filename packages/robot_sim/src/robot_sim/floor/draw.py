"""Draw a floor plan into map_server's map: ``<map>.yaml`` + a trinary image (254 free,
0 occupied, 205 unknown), what ``nav2_map_server`` loads and what a map made by SLAM looks like.

    python -m robot_sim.floor.draw packages/robot_sim/config/floor/office.plan.yaml
    python -m robot_sim.floor.draw --check packages/robot_sim/config/floor/office.plan.yaml

Order: every room's box is free, then every room's outline is wall, then openings and doors
are cut (doors drawn open), then furniture is occupied; outside the rooms is unknown.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

import cv2
import numpy as np
import numpy.typing as npt
import yaml

from robot_sim.floor.plan import Box, FloorPlan, Segment, load_plan

FREE, OCCUPIED, UNKNOWN = 254, 0, 205
OCCUPIED_THRESH, FREE_THRESH = 0.65, 0.196
"""map_saver's classic thresholds: 205 (unknown) reads back as neither free nor occupied."""

Pixels = npt.NDArray[np.uint8]


class Raster:
    """Metres ↔ image cells of a plan (row 0 is the image's top, the map's largest y)."""

    def __init__(self, resolution: float, origin: tuple[float, float], shape: tuple[int, int]):
        self.resolution = resolution
        self.origin = origin
        self.height, self.width = shape

    @classmethod
    def of(cls, plan: FloorPlan) -> Raster:
        width = round(plan.size[0] / plan.resolution)
        height = round(plan.size[1] / plan.resolution)
        return cls(plan.resolution, plan.origin, (height, width))

    def cells(self, box: Box) -> tuple[slice, slice]:
        """The rows and columns whose cells lie (mostly) inside ``box``."""
        x0, y0, x1, y1 = box
        res, (ox, oy) = self.resolution, self.origin
        c0, c1 = round((x0 - ox) / res), round((x1 - ox) / res)
        r0 = self.height - round((y1 - oy) / res)
        r1 = self.height - round((y0 - oy) / res)
        return (
            slice(max(0, r0), min(self.height, max(r1, r0 + 1))),
            slice(max(0, c0), min(self.width, max(c1, c0 + 1))),
        )


def segment_box(segment: Segment, across: float) -> Box:
    """The rectangle ``across`` metres wide centred on an axis-aligned segment."""
    x0, y0, x1, y1 = segment
    half = across / 2.0
    if y0 == y1:
        return (min(x0, x1), y0 - half, max(x0, x1), y0 + half)
    return (x0 - half, min(y0, y1), x0 + half, max(y0, y1))


def outline(box: Box) -> list[Segment]:
    x0, y0, x1, y1 = box
    return [(x0, y0, x1, y0), (x0, y1, x1, y1), (x0, y0, x0, y1), (x1, y0, x1, y1)]


def door_box(plan: FloorPlan, segment: Segment) -> Box:
    """The cells a door (or opening) fills when closed: the wall's thickness along it."""
    return segment_box(segment, plan.wall_thickness)


def draw(plan: FloorPlan) -> Pixels:
    raster = Raster.of(plan)
    image = np.full((raster.height, raster.width), UNKNOWN, np.uint8)
    for room in plan.rooms.values():
        image[raster.cells(room.box)] = FREE
    thickness = plan.wall_thickness
    for room in plan.rooms.values():
        for side in outline(room.box):
            x0, y0, x1, y1 = segment_box(side, thickness)
            grown = (
                (x0 - thickness / 2, y0, x1 + thickness / 2, y1)
                if side[1] == side[3]
                else (x0, y0 - thickness / 2, x1, y1 + thickness / 2)
            )
            image[raster.cells(grown)] = OCCUPIED
    cut = thickness + 2 * plan.resolution  # the whole wall, whatever the rounding
    for segment in [*plan.openings, *(door.segment for door in plan.doors.values())]:
        image[raster.cells(segment_box(segment, cut))] = FREE
    for item in plan.furniture.values():
        image[raster.cells(item.box)] = OCCUPIED
    return image


def map_yaml(plan: FloorPlan) -> dict[str, object]:
    """map_server's map description (``nav2_map_server`` / ``map_server`` YAML keys)."""
    return {
        "image": plan.image,
        "mode": "trinary",
        "resolution": plan.resolution,
        "origin": [plan.origin[0], plan.origin[1], 0.0],
        "negate": 0,
        "occupied_thresh": OCCUPIED_THRESH,
        "free_thresh": FREE_THRESH,
    }


def write(plan: FloorPlan, directory: Path) -> tuple[Path, Path]:
    image_path = directory / plan.image
    if not cv2.imwrite(str(image_path), draw(plan), [cv2.IMWRITE_PNG_COMPRESSION, 9]):
        raise OSError(f"cannot write {image_path}")
    yaml_path = directory / plan.map
    header = (
        "# map_server's map of the office, drawn from office.plan.yaml by robot_sim.floor.draw\n"
    )
    yaml_path.write_text(header + yaml.safe_dump(map_yaml(plan), sort_keys=False))
    return yaml_path, image_path


def check(plan: FloorPlan, directory: Path) -> list[str]:
    """What differs between the committed map and what the plan draws (empty: up to date)."""
    problems = []
    image = cv2.imread(str(directory / plan.image), cv2.IMREAD_UNCHANGED)
    if image is None:
        problems.append(f"{plan.image} is missing or unreadable")
    elif image.shape != draw(plan).shape or not np.array_equal(image, draw(plan)):
        problems.append(f"{plan.image} differs from what the plan draws")
    try:
        committed = yaml.safe_load((directory / plan.map).read_text())
    except OSError:
        committed = None
    if committed != map_yaml(plan):
        problems.append(f"{plan.map} differs from the plan's map description")
    return problems


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m robot_sim.floor.draw", description=__doc__)
    parser.add_argument("plan", type=Path, help="the floor plan YAML")
    parser.add_argument("--check", action="store_true", help="only check the committed map")
    args = parser.parse_args(argv)
    plan = load_plan(args.plan)
    directory = args.plan.parent
    if args.check:
        problems = check(plan, directory)
        for problem in problems:
            sys.stderr.write(problem + "\n")
        return 1 if problems else 0
    for path in write(plan, directory):
        sys.stdout.write(f"wrote {path}\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
