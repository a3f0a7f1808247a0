"""Every test keeps the manipulation server's per-user state (the outbox) in its own tmp dir:
the defaults live under XDG_DATA_HOME, never in the user's real data dir."""

from __future__ import annotations

from pathlib import Path

import pytest


@pytest.fixture(autouse=True)
def manipulation_state_in_tmp(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path / "xdg-data"))
