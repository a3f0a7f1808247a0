"""Every deployment preset of the vision node (config/deployment/*.yaml) starts exactly as
shipped through the real entry point with dummy keys: the dev preset serves /healthz; a preset
whose model weights are not on this machine refuses with exit code 2 and one line naming the
setting to fill, never a traceback. Only the artifacts port is moved off the stack's fixed one,
and frames come from a generated folder."""

from __future__ import annotations

import os
import sys
from pathlib import Path

import httpx
import pytest

from robot_mcp_perception.composition import default_config_dir
from robot_mcp_perception.sample_scenes import generate_scenes
from robot_stack_testing import ProcessLauncher, wait_until
from robot_stack_testing.processes import start_refusal

pytestmark = [pytest.mark.ros, pytest.mark.slow]

PRESETS = sorted(path.stem for path in (default_config_dir() / "deployment").glob("*.yaml"))
NEEDS = {
    "dev": None,
    "robot": "SAM_CHECKPOINT",
    "offboard_gpu": "SAM_CHECKPOINT",
    "robot_gpu": "GROUNDER_WEIGHTS",  # the on-board detector behind Gemini is built first
}


def preset_env(preset: str, port: int, frames: Path) -> dict[str, str]:
    return {
        "ROS_DOMAIN_ID": os.environ["ROS_DOMAIN_ID"],
        "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST",
        "GEMINI_API_KEY": "dummy-gemini-key",  # never used: nothing is asked at start-up
        "PERCEPTION_DEPLOYMENT": preset,
        "PERCEPTION_CONFIG_OVERRIDES": f"artifacts.port={port}",
        "PERCEPTION_FRAMES_DIR": str(frames),
    }


@pytest.fixture(scope="module")
def frames(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("scenes")
    generate_scenes(folder, count=2, size=(160, 120))
    return folder


def test_every_shipped_preset_is_booted_here() -> None:
    assert sorted(NEEDS) == PRESETS


@pytest.mark.parametrize("preset", [name for name, setting in NEEDS.items() if setting])
def test_a_preset_without_its_weights_exits_2_with_one_line_naming_the_setting(
    preset: str, frames: Path, tcp_port: int, tmp_path: Path
) -> None:
    line = start_refusal(
        "robot_mcp_perception.vision_node", tmp_path, preset_env(preset, tcp_port, frames)
    )
    assert line.startswith("vision_node: ")
    assert NEEDS[preset] in line
    assert "Error in call to target" not in line  # the adapter's own sentence, not Hydra's


def test_the_dev_preset_boots_as_shipped_and_serves_healthz(
    launcher: ProcessLauncher, frames: Path, tcp_port: int
) -> None:
    env = preset_env("dev", tcp_port, frames)
    del env["GEMINI_API_KEY"]  # dev needs no key
    process = launcher.start(
        "vision_node_dev", [sys.executable, "-m", "robot_mcp_perception.vision_node"], env=env
    )
    health: dict[str, object] = {}

    def serving() -> bool:
        assert process.running(), process.log()
        try:
            health.update(httpx.get(f"http://127.0.0.1:{tcp_port}/healthz", timeout=2).json())
        except httpx.HTTPError:
            return False
        return bool(health.get("frame"))

    wait_until(serving, 60.0, "the dev preset serving /healthz with a frame")
    models = health["models"]
    assert isinstance(models, dict)
    assert all(model["ready"] for model in models.values()), models
    assert launcher.stop(process) in (0, -2, -15), process.log()
    assert "Traceback" not in process.log()
