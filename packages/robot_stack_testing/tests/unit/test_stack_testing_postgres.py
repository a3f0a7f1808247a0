"""The throwaway PostgreSQL: a real server as an unprivileged user, stopped and deleted after."""

from __future__ import annotations

import subprocess
from pathlib import Path

import pytest

from robot_stack_testing.postgres import (
    PostgresServer,
    PostgresUnavailableError,
    find_bin_dir,
)


def psql(server: PostgresServer, dsn: str, sql: str) -> str:
    done = subprocess.run(
        [str(server.bin_dir / "psql"), dsn, "-XAtc", sql],
        capture_output=True,
        text=True,
        timeout=30,
        check=True,
    )
    return done.stdout.strip()


def test_the_session_server_answers_as_a_non_root_user_on_loopback(
    postgres_server: PostgresServer, postgres_dsn: str
) -> None:
    owner = psql(postgres_server, postgres_dsn, "SELECT current_setting('data_directory')")
    listen = psql(postgres_server, postgres_dsn, "SHOW listen_addresses")

    assert listen == "127.0.0.1"
    assert Path(owner) == postgres_server.data_dir
    assert postgres_server.data_dir.stat().st_uid != 0


def test_each_test_gets_a_fresh_empty_database(
    postgres_server: PostgresServer, postgres_dsn: str
) -> None:
    psql(postgres_server, postgres_dsn, "CREATE TABLE marker (x int)")
    other = postgres_server.create_database()

    assert other != postgres_dsn
    tables = "SELECT count(*) FROM pg_tables WHERE tablename = 'marker'"
    assert psql(postgres_server, other, tables) == "0"


def test_a_stopped_server_is_gone_with_its_files() -> None:
    server = PostgresServer.start()
    assert server.running()

    server.stop()
    server.stop()  # idempotent

    assert not server.root.exists()
    with pytest.raises(subprocess.CalledProcessError):
        psql(server, server.dsn(), "SELECT 1")


def test_a_server_killed_behind_pg_ctl_s_back_is_stopped_by_its_pid() -> None:
    server = PostgresServer.start()
    try:
        server.bin_dir = Path("/nonexistent")  # pg_ctl stop cannot run: the PID fallback must
    finally:
        server.stop()

    with pytest.raises(subprocess.CalledProcessError):
        psql(PostgresServer(bin_dir=find_bin_dir(), root=server.root), server.dsn(), "SELECT 1")


def test_missing_binaries_name_the_setup_step(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.delenv("PG_BIN_DIR", raising=False)

    with pytest.raises(PostgresUnavailableError, match="make setup"):
        find_bin_dir(tmp_path)
    monkeypatch.setenv("PG_BIN_DIR", str(tmp_path))
    assert find_bin_dir() == tmp_path
