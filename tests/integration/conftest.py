"""Cross-package tests that run in one process (no servers started): the helpers beside them
are importable by the tests and by ``benchmarks/`` (pytest runs with --import-mode=importlib)."""

from __future__ import annotations

import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from robot_voice_chat.robot_words import check_robot_words, witnessing

HERE = str(Path(__file__).parent)
if HERE not in sys.path:
    sys.path.insert(0, HERE)


@pytest.fixture(autouse=True)
def robot_words_are_plain() -> Iterator[None]:
    """What the brain's fakes were made to say is checked for leaked ids and codes (issue 31)."""
    with witnessing() as said:
        yield
    found = check_robot_words(said)
    if found:
        pytest.fail("the robot's words leak: " + "; ".join(str(leak) for leak in found[:5]))
