"""The composition root alone builds the mission executor, and the brain ships no test double
that assembles it (issue 37): the doubles live in ``robot_stack_testing.brain``."""

from __future__ import annotations

import ast
from pathlib import Path

import robot_stack_testing.brain
import robot_voice_chat


def executor_builders(root: Path) -> list[str]:
    """Modules under ``root`` that call ``MissionExecutor(...)``."""
    found = []
    for path in sorted(root.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if (
                isinstance(node, ast.Call)
                and isinstance(node.func, ast.Name)
                and node.func.id == "MissionExecutor"
            ):
                found.append(path.relative_to(root).as_posix())
    return found


def test_only_the_composition_root_builds_the_mission_executor() -> None:
    assert executor_builders(Path(robot_voice_chat.__file__).parent) == ["composition.py"]
    assert executor_builders(Path(robot_stack_testing.brain.__file__).parent) == []


def test_the_brain_ships_no_module_named_as_a_test_double_but_the_fakes_beside_their_ports() -> (
    None
):
    package = Path(robot_voice_chat.__file__).parent
    doubles = sorted(
        p.relative_to(package).as_posix()
        for p in package.rglob("*.py")
        if p.stem.startswith("fake") or p.stem in {"harness", "testing"}
    )
    assert doubles == [
        "services/llm/fake.py",
        "services/speech/fake.py",
        "services/tools/fake.py",
    ]
