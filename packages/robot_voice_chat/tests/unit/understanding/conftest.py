"""Fixtures of the understanding tests: one understanding layer (its embedder loads once) per
module."""

from __future__ import annotations

import pytest

from robot_voice_chat.services.llm.understanding.understand import Understanding


@pytest.fixture(scope="module")
def understanding() -> Understanding:
    return Understanding()
