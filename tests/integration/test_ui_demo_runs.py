"""`make demo` (scripts/ui_demo.py) runs in a directory of its own and never deletes another
run's state (issue 35: it wiped a running demo's logs, outboxes and latch directory). The
stack itself is replaced by a stand-in that writes state the way the services do."""

from __future__ import annotations

import importlib.util
import os
import signal
import stat
import subprocess
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from types import ModuleType, SimpleNamespace
from typing import Any

import pytest

SCRIPT = Path(__file__).resolve().parents[2] / "scripts" / "ui_demo.py"


def load_demo() -> ModuleType:
    spec = importlib.util.spec_from_file_location("ui_demo_under_test", SCRIPT)
    assert spec is not None
    assert spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture
def other_demo(tmp_path: Path) -> Iterator[tuple[Path, int]]:
    """A demo already running: its process and its state under build/ui-demo."""
    process = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(120)"])
    run = tmp_path / "build" / "ui-demo" / "run-20261129-080000-abcd"
    (run / "brain" / "latch").mkdir(parents=True)
    (run / "brain" / "latch" / "latched.json").write_text("{}")
    (run / "navigation-outbox.sqlite3").write_bytes(b"outbox")
    (run / "demo.pid").write_text(f"{process.pid}\n")
    try:
        yield run, process.pid
    finally:
        process.kill()
        process.wait(10)


def test_a_second_demo_gets_its_own_directory_and_leaves_the_running_ones_state(
    tmp_path: Path,
    other_demo: tuple[Path, int],
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    demo = load_demo()
    static = tmp_path / "static"
    static.mkdir()
    (static / "index.html").write_text("<!doctype html>")
    used: list[Path] = []

    @contextmanager
    def stand_in_stack(root: Path, var_dir: Path, *_: Any, **__: Any) -> Iterator[Any]:
        used.append(var_dir)
        var_dir.mkdir(parents=True, exist_ok=True)
        (var_dir / "brain.log").write_text("this run's log")
        yield SimpleNamespace(services={}, brain_url="http://127.0.0.1:1")

    async def no_seed(stack: Any) -> None:
        return None

    def interrupted() -> None:
        raise KeyboardInterrupt

    monkeypatch.setattr(demo, "VAR_DIR", tmp_path / "build" / "ui-demo")
    monkeypatch.setattr(demo, "STATIC", static)
    monkeypatch.setattr(demo, "mailroom_stack", stand_in_stack)
    monkeypatch.setattr(demo, "seed_memory", no_seed)
    monkeypatch.setattr(signal, "signal", lambda *_: None)
    monkeypatch.setattr(signal, "pause", interrupted)

    assert demo.main(["--free-ports"]) == 0
    assert demo.main(["--free-ports"]) == 0

    other, pid = other_demo
    assert (other / "brain" / "latch" / "latched.json").read_text() == "{}"
    assert (other / "navigation-outbox.sqlite3").read_bytes() == b"outbox"
    first, second = used
    assert len({first, second, other}) == 3
    assert first.parent == second.parent == other.parent
    assert (first / "brain.log").read_text() == "this run's log"  # a finished run is kept too
    for run in (first, second):
        assert stat.S_IMODE(run.stat().st_mode) == 0o700
        assert (run / "demo.pid").read_text().strip() == str(os.getpid())
    out = capsys.readouterr().out
    assert f"another demo is running (pid {pid}" in out
    assert str(second) in out
