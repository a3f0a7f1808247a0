"""``robot-sim`` as its own OS process: refuses a bad config with exit 2 and one line; ready
(PID file) with its scenes saved; stops cleanly on SIGTERM."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from robot_stack_testing import ProcessLauncher, wait_until

pytestmark = pytest.mark.ros


def test_a_bad_setting_exits_2_with_one_clear_line(tmp_path: Path) -> None:
    done = subprocess.run(
        [sys.executable, "-m", "robot_sim"],
        env={**os.environ, "SIM_WORLD": str(tmp_path / "missing.yaml")},
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert done.returncode == 2
    [line] = [json.loads(x) for x in done.stderr.splitlines() if x.startswith("{")]
    assert line["event"] == "startup_failed"
    assert "world file not found" in line["detail"]
    assert "Traceback" not in done.stderr


def test_the_process_saves_its_scenes_reports_ready_and_stops_on_sigterm(
    launcher: ProcessLauncher, tmp_path: Path
) -> None:
    ready = tmp_path / "robot-sim.pid"
    process = launcher.start(
        "robot_sim",
        [sys.executable, "-m", "robot_sim"],
        env={
            **os.environ,
            "SIM_SCENES_DIR": str(tmp_path / "scenes"),
            "SIM_READY_FILE": str(ready),
            "SIM_TIME_SCALE": "10",
        },
    )
    wait_until(
        lambda: ready.is_file() and ready.read_text() == str(process.pid), 60.0, "the PID file"
    )
    saved = {p.name.split("-")[0] for p in (tmp_path / "scenes").glob("*.json")}
    assert saved == {"dock"}  # the first frame, there before the vision node starts
    process.popen.send_signal(signal.SIGTERM)
    assert process.popen.wait(timeout=30) == 0
    assert "robot_sim_ready" in process.log()
