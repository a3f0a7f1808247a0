"""PostgreSQL-only behaviour of the store: migrations, start-up errors, concept refresh."""

from __future__ import annotations

import threading
from typing import Any

import psycopg
import pytest

from robot_mcp_memory.documents import parse_process, render_process
from robot_mcp_memory.query import build_query
from robot_mcp_memory.store.base import StoreError
from robot_mcp_memory.store.postgres import PostgresProcessStore, search_terms
from robot_mcp_memory.store.postgres_schema import SCHEMA_VERSION
from robot_stack_testing import free_tcp_port


def test_servers_starting_together_migrate_the_database_once(postgres_dsn: str) -> None:
    opened: list[PostgresProcessStore] = []
    errors: list[BaseException] = []
    start = threading.Barrier(4)

    def open_one(index: int) -> None:
        try:
            start.wait(30)
            opened.append(PostgresProcessStore(postgres_dsn, f"robot-{index}"))
        except BaseException as exc:
            errors.append(exc)

    threads = [threading.Thread(target=open_one, args=(index,)) for index in range(4)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(60)
    for store in opened:
        store.close()

    assert errors == []
    assert len(opened) == 4
    with psycopg.connect(postgres_dsn) as conn:
        versions = conn.execute("SELECT version FROM memory_schema ORDER BY version").fetchall()
    assert versions == [(version,) for version in range(1, SCHEMA_VERSION + 1)]


def test_a_database_from_a_newer_server_is_refused(postgres_dsn: str) -> None:
    PostgresProcessStore(postgres_dsn, "robot-1").close()
    with psycopg.connect(postgres_dsn) as conn:
        conn.execute("INSERT INTO memory_schema (version) VALUES (%s)", (SCHEMA_VERSION + 1,))

    with pytest.raises(StoreError, match="newer than this server"):
        PostgresProcessStore(postgres_dsn, "robot-1")


def test_an_unreachable_server_or_a_malformed_dsn_is_a_store_error_without_the_password() -> None:
    port = free_tcp_port()

    with pytest.raises(StoreError, match="cannot open the PostgreSQL process store") as refused:
        PostgresProcessStore(f"postgresql://u:s3cret@127.0.0.1:{port}/m", "robot-1")
    with pytest.raises(StoreError, match="not a valid libpq") as malformed:
        PostgresProcessStore("password=s3cret host", "robot-1")

    assert "s3cret" not in str(refused.value)
    assert "s3cret" not in str(malformed.value)


def test_indexed_concepts_are_rederived_when_the_synonym_list_changes(
    postgres_dsn: str, docs: Any
) -> None:
    first = PostgresProcessStore(postgres_dsn, "robot-1")
    first.save(parse_process(docs.mailroom))
    first.close()
    with psycopg.connect(postgres_dsn) as conn:
        conn.execute("UPDATE processes SET concepts = ''::tsvector")
        conn.execute("UPDATE memory_meta SET value = 'old' WHERE key = 'synonyms_version'")

    reopened = PostgresProcessStore(postgres_dsn, "robot-1")
    try:
        found = [c.process.id for c in reopened.search(build_query("parcel"), 5)]
    finally:
        reopened.close()

    assert found == ["fetch-package-from-mailroom"]


def test_a_version_1_database_gets_document_lengths_and_ranks_after_migrating(
    postgres_dsn: str, docs: Any
) -> None:
    first = PostgresProcessStore(postgres_dsn, "robot-1")
    first.save(parse_process(docs.mailroom))
    first.save(parse_process(docs.reception))
    first.close()
    with psycopg.connect(postgres_dsn) as conn:  # back to what a version 1 server left
        conn.execute("ALTER TABLE processes DROP COLUMN document_length")
        conn.execute("DROP FUNCTION memory_token_count(tsvector)")
        conn.execute("DELETE FROM memory_schema WHERE version >= 2")

    reopened = PostgresProcessStore(postgres_dsn, "robot-1")
    try:
        ranked = reopened.search(build_query("mailroom package", synonyms=False), 5)
    finally:
        reopened.close()

    with psycopg.connect(postgres_dsn) as conn:
        lengths = conn.execute("SELECT document_length FROM processes").fetchall()
    assert len(lengths) == 2
    assert all(length > 10 for (length,) in lengths)
    assert [c.process.id for c in ranked] == [
        "fetch-package-from-mailroom",
        "collect-parcel-at-reception",
    ]
    assert ranked[0].relevance > ranked[1].relevance > 0


def test_term_weights_come_from_the_stores_own_scope(postgres_dsn: str, docs: Any) -> None:
    mine = PostgresProcessStore(postgres_dsn, "robot-1", visibility="robot")
    other = PostgresProcessStore(postgres_dsn, "robot-2", visibility="robot")
    try:
        for markdown in docs.all():
            mine.save(parse_process(markdown))
        query = build_query("mailroom package", synonyms=False)
        before = [(c.process.id, c.relevance) for c in mine.search(query, 5)]
        for index in range(20):  # "mailroom" in every process of another robot's scope
            other.save(
                parse_process(
                    render_process(
                        f"mailroom-round-{index}",
                        "Mailroom round",
                        "visit the mailroom",
                        [],
                        ["go"],
                    )
                )
            )
        after = [(c.process.id, c.relevance) for c in mine.search(query, 5)]
    finally:
        mine.close()
        other.close()

    assert after == before
    assert before[0][0] == "fetch-package-from-mailroom"


def test_a_store_whose_server_went_away_reports_store_errors(postgres_dsn: str) -> None:
    store = PostgresProcessStore(postgres_dsn, "robot-1", connect_timeout_s=1)
    store.close()

    with pytest.raises(StoreError, match="listing processes failed"):
        store.list_processes()


def test_search_terms_are_distinct_with_whitespace_collapsed() -> None:
    assert search_terms(("pick  up", 'we"ird', "or", "or", " ", "")) == ["pick up", 'we"ird', "or"]
