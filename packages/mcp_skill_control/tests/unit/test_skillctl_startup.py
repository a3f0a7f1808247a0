"""A configuration the server cannot start with: exit code 2 and one line, no traceback."""

from __future__ import annotations

from pathlib import Path

import pytest

from robot_stack_testing import start_refusal


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
    line = start_refusal("mcp_skill_control", tmp_path, env)
    assert line.startswith("mcp-skill-control: cannot start: ")
    assert says in line


def test_a_catalog_that_does_not_validate_exits_2_with_one_line(tmp_path: Path) -> None:
    catalog = tmp_path / "skills.yaml"
    catalog.write_text("templates:\n  - {name: bad, skill: {mode: region}}\n", encoding="utf-8")
    line = start_refusal("mcp_skill_control", tmp_path, {"SKILLS_CATALOG": str(catalog)})
    assert line.startswith("mcp-skill-control: cannot start: missing_grounding")
