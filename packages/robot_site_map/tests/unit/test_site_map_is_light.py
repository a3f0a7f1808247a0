"""Both the simulator and the navigation server import this package: it must load neither of
them, nor ROS, nor the MCP SDK, nor numpy."""

from __future__ import annotations

import subprocess
import sys

HEAVY = {"rclpy", "mcp", "numpy", "cv2", "robot_sim", "robot_mcp_navigation", "robot_mcp_kit"}


def test_importing_the_site_map_loads_neither_reader_nor_ros_nor_the_mcp_sdk() -> None:
    listing = subprocess.run(
        [sys.executable, "-c", "import sys, robot_site_map; print(*sys.modules, sep='\\n')"],
        capture_output=True,
        text=True,
        check=True,
        timeout=60,
    ).stdout.split()
    loaded = {name.partition(".")[0] for name in listing}

    assert "robot_site_map" in loaded
    assert loaded.isdisjoint(HEAVY), sorted(loaded & HEAVY)
