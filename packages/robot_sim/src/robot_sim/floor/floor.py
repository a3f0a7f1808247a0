"""The floor robot-sim lives on: the plan (doors, furniture, rooms) and the occupancy grid of
its map_server map, with each door's cells."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from robot_sim.floor.draw import door_box
from robot_sim.floor.grid import Grid, Mask, load_grid
from robot_sim.floor.plan import FloorError, FloorPlan, load_plan


@dataclass(frozen=True)
class Floor:
    plan: FloorPlan
    grid: Grid
    """The map as map_server publishes it (doors drawn open)."""
    door_cells: dict[str, Mask]

    def with_doors_closed(self, doors: Iterable[str]) -> Grid:
        """The grid with ``doors`` filled in."""
        mask = np.zeros(self.grid.cells.shape, bool)
        for door in doors:
            mask |= self.door_cells[door]
        return self.grid.with_occupied(mask) if mask.any() else self.grid


def load_floor(plan_path: Path) -> Floor:
    """The plan and the map it names (``map:``, relative to the plan); FloorError otherwise."""
    plan = load_plan(plan_path)
    grid = load_grid(plan_path.parent / plan.map)
    doors = {name: grid.box_mask(door_box(plan, door.segment)) for name, door in plan.doors.items()}
    empty = sorted(name for name, cells in doors.items() if not cells.any())
    if empty:
        raise FloorError(f"{plan_path}: doors {empty} cover no cell of the map")
    return Floor(plan, grid, doors)
