"""Our nav2_msgs definitions are byte-identical to the named Nav2 release (upstream/UPSTREAM.json),
so the type hashes match and this package talks to a real Nav2 of that release."""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import subprocess
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import pytest

PACKAGE = Path(__file__).resolve().parents[1]
UPSTREAM = PACKAGE / "upstream"
INTERFACES = PACKAGE.parent


def manifest() -> dict[str, Any]:
    data: dict[str, Any] = json.loads((UPSTREAM / "UPSTREAM.json").read_text())
    return data


def git_blob_id(content: bytes) -> str:
    """What `git hash-object` prints: upstream's tree lists this id for the file."""
    return hashlib.sha1(b"blob %d\0" % len(content) + content, usedforsecurity=False).hexdigest()


def interface_files() -> list[Path]:
    return sorted(
        p for kind in ("msg", "srv", "action") for p in (PACKAGE / kind).glob(f"*.{kind}")
    )


def test_the_release_is_named_with_its_commit() -> None:
    data = manifest()
    assert data["repository"] == "https://github.com/ros-navigation/navigation2"
    assert data["ros_distro"] == "kilted"
    assert len(data["commit"]) == 40
    int(data["commit"], 16)
    assert data["commit"] in (PACKAGE / "README.md").read_text()
    assert data["tag"] in (PACKAGE / "README.md").read_text()


@pytest.mark.parametrize("upstream_path", sorted(manifest()["files"]))
def test_every_definition_is_byte_identical_to_the_upstream_copy(upstream_path: str) -> None:
    entry = manifest()["files"][upstream_path]
    ours = (PACKAGE / entry["ours"]).read_bytes()
    theirs = (UPSTREAM / entry["copy"]).read_bytes()
    assert ours == theirs, f"{entry['ours']} differs from upstream {upstream_path}"
    assert git_blob_id(ours) == entry["git_blob"], "not the blob upstream's commit holds"
    assert Path(upstream_path).name == Path(entry["ours"]).name


def test_every_built_definition_comes_from_upstream() -> None:
    tracked = {PACKAGE / entry["ours"] for entry in manifest()["files"].values()}
    assert set(interface_files()) == tracked
    cmake = (PACKAGE / "CMakeLists.txt").read_text()
    for path in interface_files():
        assert f'"{path.relative_to(PACKAGE)}"' in cmake


def test_package_name_and_version_are_the_release() -> None:
    root = ET.parse(PACKAGE / "package.xml").getroot()  # noqa: S314 - our own file
    assert root.findtext("name") == "nav2_msgs"
    assert root.findtext("version") == manifest()["release"]
    assert "project(nav2_msgs)" in (PACKAGE / "CMakeLists.txt").read_text()


def test_the_generated_action_has_the_release_fields() -> None:
    from nav2_msgs.action import NavigateToPose

    assert set(NavigateToPose.Goal.get_fields_and_field_types()) == {"pose", "behavior_tree"}
    assert set(NavigateToPose.Result.get_fields_and_field_types()) == {"error_code", "error_msg"}
    assert set(NavigateToPose.Feedback.get_fields_and_field_types()) == {
        "current_pose",
        "navigation_time",
        "estimated_time_remaining",
        "number_of_recoveries",
        "distance_remaining",
    }
    assert (NavigateToPose.Result.UNKNOWN, NavigateToPose.Result.TIMEOUT) == (9000, 9003)


def test_colcon_skips_our_nav2_msgs_so_a_system_ros_keeps_its_own(tmp_path: Path) -> None:
    colcon = shutil.which("colcon")
    assert colcon is not None, "colcon (dev dependency) is missing from the venv"
    env = {k: v for k, v in os.environ.items() if not k.startswith(("AMENT_", "COLCON_"))}
    env["COLCON_HOME"] = str(tmp_path)
    listed = subprocess.run(
        [colcon, "list", "--names-only", "--base-paths", str(INTERFACES)],
        capture_output=True,
        text=True,
        env=env,
        cwd=tmp_path,  # colcon writes its log/ folder here, not into the checkout
        timeout=120,
        check=True,
    ).stdout.split()
    assert "ros2_vision_interfaces" in listed  # the check can fail: colcon does see packages
    assert "nav2_msgs" not in listed
