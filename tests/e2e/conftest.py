"""Every e2e test that drives the brain as a user (``MissionDriver``) has every sentence the
robot said or showed checked for leaked task ids, tool names, codes and snake_case ids (issue
31), also in tests written later."""

from __future__ import annotations

import pytest

from robot_stack_testing.mission_driver import MissionDriver
from robot_voice_chat.robot_words import leaks


@pytest.fixture(autouse=True)
def robot_words_checked(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(MissionDriver, "words_check", staticmethod(leaks))
