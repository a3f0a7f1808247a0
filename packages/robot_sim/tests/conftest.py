"""Fixtures shared by the robot_sim tests."""

from __future__ import annotations

from pathlib import Path

import pytest

from robot_sim.config import SimSettings, default_world_path

WORLD = default_world_path()


@pytest.fixture
def settings(tmp_path: Path) -> SimSettings:
    return SimSettings(SIM_WORLD=WORLD, SIM_SCENES_DIR=tmp_path / "scenes", SIM_TIME_SCALE=20.0)
