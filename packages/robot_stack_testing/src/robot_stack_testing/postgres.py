"""A throwaway PostgreSQL server for tests, from Debian's ``postgresql`` package.

``initdb`` in a fresh temporary directory, the server listening on 127.0.0.1 at a free port
(and on a unix socket inside that directory), trust authentication for the ``postgres`` role,
durability off (it is thrown away). PostgreSQL refuses to run as root, and CI runs as root: then
every server command runs as Debian's ``postgres`` system user through ``runuser`` and the
directory is handed to that user. :meth:`PostgresServer.stop` stops it by its own data
directory (``pg_ctl stop``), falling back to the PID in ``postmaster.pid``, and removes the
directory. Client programs (``createdb``, ``psql``) run as the caller over TCP.
"""

from __future__ import annotations

import os
import pwd
import shutil
import signal
import subprocess
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass, field
from itertools import count
from pathlib import Path

from robot_stack_testing.ports import free_tcp_port
from robot_stack_testing.waiting import wait_until

POSTGRES_ROOT = Path("/usr/lib/postgresql")
SYSTEM_USER = "postgres"
SUPERUSER = "postgres"
START_TIMEOUT_S = 60
_START_ATTEMPTS = 3  # a free port can be taken between picking it and binding it


class PostgresUnavailableError(RuntimeError):
    """The server binaries are missing or the server did not start."""


def find_bin_dir(root: Path = POSTGRES_ROOT) -> Path:
    """``/usr/lib/postgresql/<newest version>/bin`` (``PG_BIN_DIR`` overrides)."""
    override = os.environ.get("PG_BIN_DIR")
    if override:
        return Path(override)
    found = sorted(
        (path.parent for path in root.glob("*/bin/pg_ctl")),
        key=lambda path: int(path.parent.name) if path.parent.name.isdigit() else 0,
    )
    if not found:
        raise PostgresUnavailableError(
            f"no PostgreSQL server under {root}/<version>/bin: run `make setup` "
            "(it installs Debian's postgresql package)"
        )
    return found[-1]


def _as_server_user() -> list[str]:
    """The argv prefix that runs a server command as an unprivileged user."""
    if os.geteuid() != 0:
        return []
    try:
        pwd.getpwnam(SYSTEM_USER)
    except KeyError as exc:
        raise PostgresUnavailableError(
            f"running as root and there is no '{SYSTEM_USER}' system user to run PostgreSQL as"
        ) from exc
    return ["runuser", "-u", SYSTEM_USER, "--"]


def _run(argv: Sequence[str], timeout_s: float) -> subprocess.CompletedProcess[str]:
    return subprocess.run(  # noqa: S603 - fixed programs, arguments built here
        list(argv), capture_output=True, text=True, timeout=timeout_s, check=False
    )


@dataclass
class PostgresServer:
    """One running throwaway server; :meth:`start` it, :meth:`stop` it (idempotent)."""

    bin_dir: Path
    root: Path
    port: int = 0
    _databases: count[int] = field(default_factory=lambda: count(1))

    @property
    def data_dir(self) -> Path:
        return self.root / "data"

    @property
    def log_path(self) -> Path:
        return self.root / "server.log"

    @classmethod
    def start(cls, bin_dir: Path | None = None) -> PostgresServer:
        prefix = _as_server_user()
        root = Path(tempfile.mkdtemp(prefix="pg-test-"))
        server = cls(bin_dir=bin_dir or find_bin_dir(), root=root)
        try:
            if prefix:
                user = pwd.getpwnam(SYSTEM_USER)
                os.chown(root, user.pw_uid, user.pw_gid)
            server._initdb(prefix)
            server._start(prefix)
        except BaseException:
            server.stop()
            raise
        return server

    def _initdb(self, prefix: list[str]) -> None:
        done = _run(
            [
                *prefix,
                str(self.bin_dir / "initdb"),
                "-D",
                str(self.data_dir),
                "-U",
                SUPERUSER,
                "--auth=trust",
                "-E",
                "UTF8",
                "--no-locale",
                "--no-sync",
            ],
            timeout_s=120,
        )
        if done.returncode != 0:
            raise PostgresUnavailableError(f"initdb failed: {done.stderr.strip()}")

    def _start(self, prefix: list[str]) -> None:
        for _ in range(_START_ATTEMPTS):
            self.port = free_tcp_port()
            options = " ".join(
                [
                    "-c listen_addresses=127.0.0.1",
                    f"-c port={self.port}",
                    f"-c unix_socket_directories={self.root}",
                    "-c fsync=off",
                    "-c synchronous_commit=off",
                    "-c full_page_writes=off",
                    "-c max_connections=200",
                ]
            )
            done = _run(
                [
                    *prefix,
                    str(self.bin_dir / "pg_ctl"),
                    "-D",
                    str(self.data_dir),
                    "-l",
                    str(self.log_path),
                    "-o",
                    options,
                    "-w",
                    "-t",
                    str(START_TIMEOUT_S),
                    "start",
                ],
                timeout_s=START_TIMEOUT_S + 10,
            )
            if done.returncode == 0:
                return
        log = self.log_path.read_text(errors="replace") if self.log_path.exists() else ""
        raise PostgresUnavailableError(f"PostgreSQL did not start: {done.stderr.strip()}\n{log}")

    def dsn(self, database: str = "postgres") -> str:
        return f"postgresql://{SUPERUSER}@127.0.0.1:{self.port}/{database}"

    def create_database(self, prefix: str = "test") -> str:
        """A new empty database; returns its DSN."""
        name = f"{prefix}_{next(self._databases)}"
        done = _run(
            [
                str(self.bin_dir / "createdb"),
                "-h",
                "127.0.0.1",
                "-p",
                str(self.port),
                "-U",
                SUPERUSER,
                "-T",
                "template0",
                name,
            ],
            timeout_s=30,
        )
        if done.returncode != 0:
            raise PostgresUnavailableError(f"createdb {name} failed: {done.stderr.strip()}")
        return self.dsn(name)

    def running(self) -> bool:
        return (self.data_dir / "postmaster.pid").exists()

    def stop(self) -> None:
        """Stop the server (by its data directory, else by its PID) and delete its files."""
        try:
            if self.running():
                try:
                    done = _run(
                        [
                            *_as_server_user(),
                            str(self.bin_dir / "pg_ctl"),
                            "-D",
                            str(self.data_dir),
                            "-m",
                            "immediate",
                            "-w",
                            "-t",
                            "30",
                            "stop",
                        ],
                        timeout_s=40,
                    )
                    stopped = done.returncode == 0
                except (OSError, subprocess.TimeoutExpired):
                    stopped = False
                if not stopped and self.running():
                    self._kill_postmaster()
        finally:
            shutil.rmtree(self.root, ignore_errors=True)

    def _kill_postmaster(self, timeout_s: float = 30.0) -> None:
        try:
            pid = int((self.data_dir / "postmaster.pid").read_text().splitlines()[0])
        except (OSError, ValueError, IndexError):
            return

        def gone() -> bool:
            try:
                os.kill(pid, 0)
            except ProcessLookupError:
                return True
            return False

        try:
            os.kill(pid, signal.SIGQUIT)  # the postmaster's immediate shutdown
        except ProcessLookupError:
            return
        wait_until(gone, timeout_s, f"PostgreSQL postmaster {pid} to exit")
