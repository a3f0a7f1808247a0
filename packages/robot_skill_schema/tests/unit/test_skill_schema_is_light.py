"""The schema package must stay importable without ROS, OpenCV or model SDKs (ARCHITECTURE §6a)."""

from __future__ import annotations

import json
import subprocess
import sys

HEAVY = ("rclpy", "cv2", "numpy", "google.genai", "hydra", "omegaconf", "robot_mcp_perception")


def test_importing_the_schema_loads_no_heavy_dependency() -> None:
    code = (
        "import json, sys; import robot_skill_schema; "
        f"print(json.dumps([m for m in {HEAVY!r} if m in sys.modules]))"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=60
    )

    assert json.loads(done.stdout) == []
