"""The office floor as map_server's map: the format, the committed image is what the plan
draws, every named place lies in free space, and planned paths never cross a wall."""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import cv2
import numpy as np
import pytest
import yaml
from skimage.draw import line

from robot_sim.config import default_world_path
from robot_sim.floor import draw
from robot_sim.floor.floor import load_floor
from robot_sim.floor.grid import FREE, OCCUPIED, UNKNOWN, load_grid
from robot_sim.floor.plan import FloorError, load_plan
from robot_sim.planner import GridPlanner, NoPathError, path_length
from robot_site_map import Location, load_map

PLAN = default_world_path().parents[1] / "floor" / "office.plan.yaml"
MAP_YAML = PLAN.parent / "office.yaml"


def office_places() -> dict[str, Location]:
    """The named places of the map the shipped world reads (the navigation server's map)."""
    world = default_world_path()
    return load_map(world.parent / yaml.safe_load(world.read_text())["map"]).locations


def test_the_map_is_map_servers_format_a_trinary_image_with_its_yaml() -> None:
    meta = yaml.safe_load(MAP_YAML.read_text())
    assert set(meta) == {
        "image", "mode", "resolution", "origin", "negate", "occupied_thresh", "free_thresh",
    }  # fmt: skip
    assert (meta["mode"], meta["negate"], meta["resolution"]) == ("trinary", 0, 0.05)
    assert len(meta["origin"]) == 3
    assert 0 < meta["free_thresh"] < meta["occupied_thresh"] < 1
    pixels = cv2.imread(str(MAP_YAML.parent / meta["image"]), cv2.IMREAD_UNCHANGED)
    assert pixels.ndim == 2
    assert pixels.dtype == np.uint8
    assert set(np.unique(pixels).tolist()) == {draw.FREE, draw.OCCUPIED, draw.UNKNOWN}
    assert (MAP_YAML.parent / meta["image"]).stat().st_size < 20_000  # small, reviewable


def test_the_committed_map_is_what_the_plan_draws() -> None:
    assert draw.check(load_plan(PLAN), PLAN.parent) == []


def test_the_grid_reads_the_image_bottom_row_first_as_occupancy_values() -> None:
    grid = load_grid(MAP_YAML)
    pixels = cv2.imread(str(PLAN.parent / "office.png"), cv2.IMREAD_GRAYSCALE)
    assert grid.cells.shape == pixels.shape
    assert set(np.unique(grid.cells).tolist()) == {FREE, OCCUPIED, UNKNOWN}
    assert (grid.cells[0] == UNKNOWN).all()
    assert (pixels[-1] == draw.UNKNOWN).all()
    row, col = grid.cell_of(0.0, 0.0)  # the dock, in the hall
    assert grid.cells[row, col] == FREE
    assert np.array_equal(grid.cells[::-1] == OCCUPIED, pixels == draw.OCCUPIED)


def test_every_named_place_lies_in_free_space_clear_of_walls_and_furniture() -> None:
    grid = load_grid(MAP_YAML)
    costmap = GridPlanner().costmap(grid)
    for name, place in office_places().items():
        cell = grid.cell_of(place.x, place.y)
        assert grid.inside(*cell), name
        assert grid.cells[cell] == FREE, name
        assert math.isfinite(costmap.cost[cell]), f"{name} is inside the robot's inflation"


def test_a_planned_path_never_crosses_a_wall_cell() -> None:
    floor = load_floor(PLAN)
    grid = floor.with_doors_closed(["mailroom_west_door"])
    planner = GridPlanner()
    costmap = planner.costmap(grid)
    places = office_places()
    for a, b in itertools.combinations(places.values(), 2):
        points = planner.plan(costmap, (a.x, a.y), (b.x, b.y))
        assert points[0] == (a.x, a.y)
        assert points[-1] == (b.x, b.y)
        assert path_length(points) >= math.dist((a.x, a.y), (b.x, b.y)) - 1e-6
        for (x0, y0), (x1, y1) in itertools.pairwise(points):
            rows, cols = line(*grid.cell_of(x0, y0), *grid.cell_of(x1, y1))
            assert not grid.occupied[rows, cols].any(), (a, b)


def test_closing_a_door_fills_its_cells_and_both_mailroom_doors_leave_no_path() -> None:
    floor = load_floor(PLAN)
    door = floor.door_cells["mailroom_west_door"]
    assert floor.grid.free[door].all()
    assert floor.with_doors_closed(["mailroom_west_door"]).occupied[door].all()
    planner = GridPlanner()
    closed = floor.with_doors_closed(["mailroom_west_door", "mailroom_east_entrance"])
    with pytest.raises(NoPathError) as error:
        planner.plan(planner.costmap(closed), (0.0, 0.0), (17.0, 3.0))
    assert error.value.code == 208
    with pytest.raises(NoPathError) as outside:
        planner.plan(planner.costmap(floor.grid), (0.0, 0.0), (40.0, 3.0))
    assert outside.value.code == 204


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("rooms: {}\n", "rooms"),
        ("doors: {d: {label: d, segment: [0, 0, 1, 1]}}\n", "horizontal or vertical"),
        (
            "furniture: {t: {label: t, box: [1, 1, 0, 0], height: 1, colour: [1, 2, 3]}}\n",
            "x0 < x1",
        ),
    ],
)
def test_a_bad_plan_names_the_problem(tmp_path: Path, text: str, message: str) -> None:
    base = yaml.safe_load(PLAN.read_text())
    base.update(yaml.safe_load(text))
    bad = tmp_path / "plan.yaml"
    bad.write_text(yaml.safe_dump(base))
    with pytest.raises(FloorError, match=message):
        load_plan(bad)


def test_a_missing_or_broken_map_is_a_floor_error(tmp_path: Path) -> None:
    with pytest.raises(FloorError, match="not found"):
        load_grid(tmp_path / "nope.yaml")
    (tmp_path / "m.yaml").write_text("image: gone.png\nresolution: 0.05\norigin: [0, 0, 0]\n")
    with pytest.raises(FloorError, match="missing or unreadable"):
        load_grid(tmp_path / "m.yaml")
    (tmp_path / "r.yaml").write_text("image: x.png\nresolution: 0.05\norigin: [0, 0, 1.0]\n")
    with pytest.raises(FloorError, match="rotated"):
        load_grid(tmp_path / "r.yaml")


def test_the_draw_command_writes_and_checks_the_map(tmp_path: Path) -> None:
    plan = tmp_path / "office.plan.yaml"
    plan.write_text(PLAN.read_text())
    assert draw.main(["--check", str(plan)]) == 1  # nothing drawn there yet
    assert draw.main([str(plan)]) == 0
    assert draw.main(["--check", str(plan)]) == 0
    assert load_grid(tmp_path / "office.yaml").cells.shape == (400, 480)
