"""A configuration the server cannot start with: exit code 2 and one line, no traceback."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest


@pytest.mark.parametrize(
    ("env", "says"),
    [
        ({"MCP_TRANSPORT": "pigeon"}, "MCP_TRANSPORT"),
        ({"SKILL_CONTROL_CALL_TIMEOUT_S": "soon"}, "call_timeout_s"),
        ({"SKILLS_CATALOG": "/nonexistent/skills.yaml"}, "skills_catalog"),
    ],
)
def test_a_bad_setting_exits_2_with_one_line(
    tmp_path: Path, env: dict[str, str], says: str
) -> None:
    done = subprocess.run(
        [sys.executable, "-m", "mcp_skill_control"],
        env={"PATH": os.environ["PATH"], "HOME": str(tmp_path), **env},
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert done.returncode == 2, done.stderr
    assert done.stdout == ""
    assert done.stderr.count("\n") == 1
    assert done.stderr.startswith("mcp-skill-control: cannot start: ")
    assert says in done.stderr


def test_a_catalog_that_does_not_validate_exits_2_with_one_line(tmp_path: Path) -> None:
    catalog = tmp_path / "skills.yaml"
    catalog.write_text("templates:\n  - {name: bad, skill: {mode: region}}\n", encoding="utf-8")
    done = subprocess.run(
        [sys.executable, "-m", "mcp_skill_control"],
        env={"PATH": os.environ["PATH"], "HOME": str(tmp_path), "SKILLS_CATALOG": str(catalog)},
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert done.returncode == 2, done.stderr
    assert done.stderr.splitlines()[-1].startswith(
        "mcp-skill-control: cannot start: missing_grounding"
    )
