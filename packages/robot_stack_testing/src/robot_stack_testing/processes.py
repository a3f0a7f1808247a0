"""Start helper processes for tests and always stop them, by PID, on teardown."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path


@dataclass
class LaunchedProcess:
    name: str
    popen: subprocess.Popen[bytes]
    log_path: Path

    @property
    def pid(self) -> int:
        return self.popen.pid

    def log(self) -> str:
        return self.log_path.read_text(errors="replace") if self.log_path.exists() else ""

    def running(self) -> bool:
        return self.popen.poll() is None


class ProcessLauncher:
    """Launches argv lists (never a shell) with stdout+stderr captured to a log file.

    ``umask`` (e.g. ``0o077``, the local stack's): every process starts with it, so what it
    creates is private to this user, and the log files are created 0600."""

    def __init__(self, log_dir: Path, umask: int | None = None) -> None:
        self._log_dir = log_dir
        self._umask = umask
        self._processes: list[LaunchedProcess] = []

    def start(
        self,
        name: str,
        argv: Sequence[str],
        env: Mapping[str, str] | None = None,
        cwd: Path | None = None,
    ) -> LaunchedProcess:
        log_path = self._log_dir / f"{name}-{len(self._processes)}.log"
        full_env = {**os.environ, **(env or {})}
        full_env.setdefault("PYTHONUNBUFFERED", "1")
        log_mode = 0o666 if self._umask is None else 0o600
        flags = os.O_WRONLY | os.O_CREAT | os.O_TRUNC
        with os.fdopen(os.open(log_path, flags, log_mode), "wb") as log:
            if self._umask is not None:
                os.fchmod(log.fileno(), 0o600)  # also a log left by an earlier run
            popen = subprocess.Popen(  # noqa: S603 - argv list from the test itself
                list(argv),
                stdout=log,
                stderr=subprocess.STDOUT,
                stdin=subprocess.DEVNULL,
                env=full_env,
                cwd=cwd,
                umask=-1 if self._umask is None else self._umask,
            )
        launched = LaunchedProcess(name, popen, log_path)
        self._processes.append(launched)
        return launched

    def stop(self, process: LaunchedProcess, timeout_s: float = 5.0) -> int:
        """SIGINT, then SIGTERM, then SIGKILL; returns the exit code."""
        for sig in (signal.SIGINT, signal.SIGTERM):
            if process.popen.poll() is not None:
                break
            process.popen.send_signal(sig)
            try:
                process.popen.wait(timeout=timeout_s)
            except subprocess.TimeoutExpired:
                continue
        if process.popen.poll() is None:
            process.popen.kill()
            process.popen.wait(timeout=timeout_s)
        return process.popen.returncode

    def stop_all(self) -> None:
        for process in reversed(self._processes):
            self.stop(process)
        self._processes.clear()


def start_refusal(module: str, home: Path, env: Mapping[str, str], timeout_s: float = 60.0) -> str:
    """Run ``python -m module`` with only PATH, HOME and ``env``: it must refuse to start the
    way every server here does (exit 2, nothing on stdout, exactly one line on stderr, no
    traceback). Returns that line."""
    done = subprocess.run(  # noqa: S603 - argv list from the test itself
        [sys.executable, "-m", module],
        env={"PATH": os.environ["PATH"], "HOME": str(home), **env},
        capture_output=True,
        text=True,
        timeout=timeout_s,
        check=False,
    )
    assert done.returncode == 2, done.stderr
    assert done.stdout == "", done.stdout
    assert done.stderr.count("\n") == 1, done.stderr
    return done.stderr.rstrip("\n")
