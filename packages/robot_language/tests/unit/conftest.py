"""Fixtures of the understanding tests: one understanding layer (its embedder loads once) per
module."""

from __future__ import annotations

import pytest

from robot_language.understand import Understanding


@pytest.fixture(scope="module")
def understanding() -> Understanding:
    return Understanding()
