"""ROS 2 packaging: colcon builds the ROS packages against the pip wheels, and the launch
file's arguments reach the vision node (there is no `launch` wheel: the launch description
is built with stand-ins of the launch classes that record what they were given)."""

from __future__ import annotations

import importlib.util
import os
import shlex
import subprocess
import sys
import types
from pathlib import Path
from typing import Any

import pytest
import yaml

from robot_mcp_perception.composition import compose_config
from robot_mcp_perception.settings import ROS_PARAMETERS, NodeSettings

ROOT = Path(__file__).resolve().parents[2]
PERCEPTION = ROOT / "packages/robot_mcp_perception"
LAUNCH_FILE = PERCEPTION / "launch/vision.launch.py"


class Recorded:
    """A launch action/substitution stand-in: keeps its positional and keyword arguments."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        self.args = args
        self.kwargs = kwargs


def _stub_modules() -> dict[str, types.ModuleType]:
    kinds = {
        "launch": ["LaunchDescription"],
        "launch.actions": ["DeclareLaunchArgument", "SetEnvironmentVariable"],
        "launch.substitutions": ["EnvironmentVariable", "LaunchConfiguration"],
        "launch_ros.actions": ["Node"],
    }
    modules = {"launch_ros": types.ModuleType("launch_ros")}
    for module_name, classes in kinds.items():
        module = types.ModuleType(module_name)
        for cls in classes:
            setattr(module, cls, type(cls, (Recorded,), {}))
        modules[module_name] = module
    return modules


@pytest.fixture
def description(monkeypatch: pytest.MonkeyPatch) -> list[Recorded]:
    for name, module in _stub_modules().items():
        monkeypatch.setitem(sys.modules, name, module)
    spec = importlib.util.spec_from_file_location("vision_launch", LAUNCH_FILE)
    assert spec is not None
    assert spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return list(module.generate_launch_description().args[0])


def resolve(value: Any, args: dict[str, str], env: dict[str, str]) -> str:
    """Evaluate a substitution the way `ros2 launch` does (strings and lists concatenate)."""
    if isinstance(value, str):
        return value
    if isinstance(value, list):
        return "".join(resolve(v, args, env) for v in value)
    kind = type(value).__name__
    if kind == "LaunchConfiguration":
        return args[value.args[0]]
    if kind == "EnvironmentVariable":
        return env.get(value.args[0], resolve(value.kwargs.get("default_value", ""), args, env))
    raise AssertionError(f"unexpected substitution {kind}")


def launch(actions: list[Recorded], given: dict[str, str]) -> tuple[dict[str, Any], str]:
    """(node parameters as launch_ros types them, PERCEPTION_CONFIG_OVERRIDES) for ``given``."""
    args: dict[str, str] = {}
    for action in actions:
        if type(action).__name__ == "DeclareLaunchArgument":
            name = action.args[0]
            args[name] = given.get(name, resolve(action.kwargs["default_value"], args, {}))
    env_action = next(a for a in actions if type(a).__name__ == "SetEnvironmentVariable")
    overrides = resolve(env_action.args[1], args, {})
    node = next(a for a in actions if type(a).__name__ == "Node")
    params = {
        key: yaml.safe_load(resolve(value, args, {}))  # launch_ros types values as YAML
        for key, value in node.kwargs["parameters"][0].items()
    }
    return params, overrides


def node_parameters() -> tuple[set[str], set[str]]:
    """(declared, read): the node declares every name of ``ROS_PARAMETERS`` and reads them all
    back into the same Pydantic validation as the Hydra config (vision_node.py)."""
    source = (PERCEPTION / "src/robot_mcp_perception/vision_node.py").read_text()
    assert "self.declare_parameter(name" in source
    assert "self.get_parameter(name)" in source
    return set(ROS_PARAMETERS), set(ROS_PARAMETERS)


def test_every_launch_argument_is_a_node_parameter_or_a_config_override(
    description: list[Recorded],
) -> None:
    declared_args = {a.args[0] for a in description if type(a).__name__ == "DeclareLaunchArgument"}
    node = next(a for a in description if type(a).__name__ == "Node")
    assert node.kwargs["package"] == "robot_mcp_perception"
    assert node.kwargs["executable"] == "vision_node"
    passed = set(node.kwargs["parameters"][0])
    declared, read = node_parameters()
    assert passed <= declared, (
        f"launch passes parameters the node never declares: {passed - declared}"
    )
    assert declared_args - {"config_overrides"} == passed
    unread = passed - read
    # a parameter the node does not read must reach it through the Hydra overrides instead
    _params, overrides = launch(description, {})
    for name in unread:
        assert f"node.{name}=" in overrides, f"launch argument {name} is ignored by the node"


def test_launch_defaults_match_the_node_defaults(description: list[Recorded]) -> None:
    params, _ = launch(description, {})
    defaults = NodeSettings()
    for name, value in params.items():
        expected = getattr(defaults, name)
        assert value == expected, name
        assert type(value) is type(expected), f"{name}: launch gives {type(value).__name__}"


def test_launch_arguments_change_what_the_node_gets(description: list[Recorded]) -> None:
    params, overrides = launch(
        description,
        {
            "camera_topic": "/front/image_raw",
            "processing_frequency": "2.5",
            "max_in_flight": "7",
            "topic_namespace": "/eyes",
            "config_overrides": "frame_source=ros segmenter=none",
        },
    )
    assert params["processing_frequency"] == 2.5
    assert params["max_in_flight"] == 7
    assert params["topic_namespace"] == "/eyes"
    cfg = compose_config(shlex.split(overrides))
    assert cfg.frame_source.topic == "/front/image_raw"
    assert cfg.segmenter._target_ == compose_config(["segmenter=none"]).segmenter._target_


@pytest.mark.slow
# The build takes 22 s on the idle 2-core machine and 46 s under two busy loops (measured,
# issue 39); a CI beside two more stacks (load 15-27) ran past the suite's 120 s default. Its
# deadline is sized from those figures with room for that load, not the unit-test default.
@pytest.mark.timeout(600)
def test_colcon_builds_the_ros_packages_against_the_pip_wheels(tmp_path: Path) -> None:
    env = {k: v for k, v in os.environ.items() if not k.startswith(("AMENT_", "COLCON_"))}
    result = subprocess.run(
        ["bash", str(ROOT / "scripts/colcon-build.sh"), str(tmp_path)],
        capture_output=True,
        text=True,
        env=env,
        timeout=570,  # ends a hung build inside the test's own 600 s, with a clear TimeoutExpired
        check=False,
    )
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    assert "3 packages finished" in result.stdout
    install = tmp_path / "install"
    share = install / "robot_mcp_perception/share/robot_mcp_perception"
    marker = "share/ament_index/resource_index/packages"
    assert (install / "robot_mcp_perception" / marker / "robot_mcp_perception").is_file()
    assert (install / "ros2_vision_interfaces" / marker / "ros2_vision_interfaces").is_file()
    assert (share / "package.xml").is_file()
    assert (share / "launch/vision.launch.py").read_text() == LAUNCH_FILE.read_text()
    assert (share / "config/config.yaml").is_file()
    assert (share / "config/frame_source/ros.yaml").is_file()
    executable = install / "robot_mcp_perception/lib/robot_mcp_perception/vision_node"
    assert os.access(executable, os.X_OK)
    site = next((install / "robot_mcp_perception/lib").glob("python3*/site-packages"))
    assert (site / "robot_mcp_perception/config/config.yaml").is_file()  # Hydra reads it here
    msgs = next((install / "ros2_vision_interfaces/lib").glob("python3*/site-packages"))
    assert (msgs / "ros2_vision_interfaces/msg/__init__.py").is_file()
    hands = next((install / "robot_manipulation_interfaces/lib").glob("python3*/site-packages"))
    assert (hands / "robot_manipulation_interfaces/action/__init__.py").is_file()
