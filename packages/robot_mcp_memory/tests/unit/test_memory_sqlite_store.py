import sqlite3
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from robot_mcp_memory.documents import parse_process
from robot_mcp_memory.query import build_query
from robot_mcp_memory.store.base import StoreError
from robot_mcp_memory.store.sqlite_fts import (
    MIGRATIONS,
    SCHEMA_VERSION,
    SqliteFtsProcessStore,
    render_match,
    scope_token,
)


@pytest.fixture
def store(tmp_path: Path) -> Iterator[SqliteFtsProcessStore]:
    opened = SqliteFtsProcessStore(tmp_path / "db" / "memory.sqlite3", "robot-1")
    yield opened
    opened.close()


def search_ids(store: SqliteFtsProcessStore, text: str, limit: int = 10) -> list[str]:
    return [candidate.process.id for candidate in store.search(build_query(text), limit)]


def test_saving_a_new_id_stores_version_one_and_creates_the_directory(
    tmp_path: Path, store: SqliteFtsProcessStore, docs: Any
) -> None:
    result = store.save(parse_process(docs.mailroom))

    assert result.created
    assert result.process.version == 1
    assert result.process.current_version == 1
    assert (tmp_path / "db" / "memory.sqlite3").exists()
    assert (
        store.get("fetch-package-from-mailroom").markdown == parse_process(docs.mailroom).markdown
    )


def test_render_match_quotes_every_term() -> None:
    assert render_match(("pick up", 'we"ird', "near", "near", " ")) == (
        '"pick up" OR "we""ird" OR "near"'
    )


def test_an_unreadable_database_path_is_a_store_error(tmp_path: Path) -> None:
    (tmp_path / "not-a-db").write_bytes(b"this is not sqlite" * 100)

    with pytest.raises(StoreError, match="cannot open the process store"):
        SqliteFtsProcessStore(tmp_path / "not-a-db", "robot-1")


def test_reads_on_a_closed_store_are_store_errors(tmp_path: Path) -> None:
    closed = SqliteFtsProcessStore(tmp_path / "m.sqlite3", "robot-1")
    closed.close()

    with pytest.raises(StoreError):
        closed.list_processes()


def test_scopes_become_single_tokens() -> None:
    assert scope_token("robot-1") == "r726f626f742d31"
    with pytest.raises(ValueError, match="robot_id"):
        SqliteFtsProcessStore(":memory:", " ")


def test_indexed_concepts_are_rederived_when_the_synonym_list_changes(
    tmp_path: Path, docs: Any
) -> None:
    path = tmp_path / "m.sqlite3"
    first = SqliteFtsProcessStore(path, "robot-1")
    first.save(parse_process(docs.mailroom))
    first.close()
    with sqlite3.connect(path) as conn:
        conn.execute("UPDATE process_fts SET concepts = '' WHERE rowid > 0")
        conn.execute("UPDATE meta SET value = 'old' WHERE key = 'synonyms_version'")

    reopened = SqliteFtsProcessStore(path, "robot-1")
    try:
        assert search_ids(reopened, "parcel") == ["fetch-package-from-mailroom"]
    finally:
        reopened.close()


def test_the_schema_version_is_recorded(tmp_path: Path) -> None:
    SqliteFtsProcessStore(tmp_path / "m.sqlite3", "robot-1").close()

    with sqlite3.connect(tmp_path / "m.sqlite3") as conn:
        assert conn.execute("PRAGMA user_version").fetchone() == (SCHEMA_VERSION,)


def test_a_version_1_file_is_migrated_with_its_processes_and_outcomes(
    tmp_path: Path, docs: Any
) -> None:
    path = tmp_path / "old.sqlite3"
    with sqlite3.connect(path) as conn:
        MIGRATIONS[1](conn)
        conn.execute("PRAGMA user_version = 1")
        conn.execute(
            "INSERT INTO processes (rowid, robot_id, process_id, current_version, created_at, "
            "updated_at) VALUES (1, 'mailbot', 'fetch-package-from-mailroom', 1, 1.0, 1.0)"
        )
        conn.execute(
            "INSERT INTO process_versions (robot_id, process_id, version, title, task_pattern, "
            "tags_json, markdown, created_at) VALUES ('mailbot', 'fetch-package-from-mailroom', "
            "1, 'Fetch a package', 'bring a package', '[]', ?, 1.0)",
            (docs.mailroom,),
        )
        conn.execute(
            "INSERT INTO outcomes (robot_id, process_id, version, success, note, recorded_at) "
            "VALUES ('mailbot', 'fetch-package-from-mailroom', 1, 1, 'ok', 2.0)"
        )
        conn.execute(
            "INSERT INTO process_fts (rowid, scope, title, task_pattern, tags, body, concepts) "
            "VALUES (1, ?, 'Fetch a package', 'bring a package', '', 'mailroom', '')",
            (scope_token("mailbot"),),
        )

    store = SqliteFtsProcessStore(path, "mailbot")
    try:
        migrated = store.get("fetch-package-from-mailroom")
        found = search_ids(store, "mailroom")
    finally:
        store.close()

    assert (migrated.saved_by, migrated.stats.successes, migrated.robot_stats.successes) == (
        "mailbot",
        1,
        1,
    )
    assert found == ["fetch-package-from-mailroom"]
    with sqlite3.connect(path) as conn:
        assert conn.execute("PRAGMA user_version").fetchone() == (SCHEMA_VERSION,)


def test_a_file_from_a_newer_server_is_refused(tmp_path: Path) -> None:
    with sqlite3.connect(tmp_path / "new.sqlite3") as conn:
        conn.execute(f"PRAGMA user_version = {SCHEMA_VERSION + 1}")

    with pytest.raises(StoreError, match="newer than this server"):
        SqliteFtsProcessStore(tmp_path / "new.sqlite3", "robot-1")
