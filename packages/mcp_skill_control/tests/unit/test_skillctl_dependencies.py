"""skill_control validates skills with the light schema package, never the vision node's code
(issue 13 item 15, ARCHITECTURE §6a)."""

from __future__ import annotations

import json
import subprocess
import sys
import tomllib
from pathlib import Path

HEAVY = ("robot_mcp_perception", "cv2", "google.genai", "hydra", "omegaconf")
PACKAGE = Path(__file__).resolve().parents[2]


def test_importing_every_module_loads_no_vision_node_dependency() -> None:
    code = (
        "import json, sys\n"
        "import mcp_skill_control.catalog, mcp_skill_control.tools\n"
        "import mcp_skill_control.server, mcp_skill_control.composition\n"
        f"print(json.dumps([m for m in {HEAVY!r} if m in sys.modules]))"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=120
    )

    assert json.loads(done.stdout.strip().splitlines()[-1]) == []


def test_the_package_does_not_depend_on_the_vision_node() -> None:
    project = tomllib.loads((PACKAGE / "pyproject.toml").read_text(encoding="utf-8"))
    dependencies = project["project"]["dependencies"]

    assert not [d for d in dependencies if d.startswith("robot-mcp-perception")]
    assert "robot-skill-schema" in dependencies
