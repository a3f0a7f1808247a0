import sqlite3
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from robot_mcp_memory.documents import parse_process
from robot_mcp_memory.query import build_query
from robot_mcp_memory.store.base import ProcessNotFoundError, SearchQuery, StoreError
from robot_mcp_memory.store.sqlite_fts import SqliteFtsProcessStore, render_match, scope_token


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


def test_saving_the_same_id_again_keeps_the_old_version(
    store: SqliteFtsProcessStore, docs: Any
) -> None:
    store.save(parse_process(docs.mailroom))
    changed = docs.mailroom.replace("desk 4", "desk 7")

    result = store.save(parse_process(changed))

    assert result.created
    assert result.process.version == 2
    assert "desk 7" in store.get("fetch-package-from-mailroom").markdown
    old = store.get("fetch-package-from-mailroom", version=1)
    assert "desk 4" in old.markdown
    assert old.current_version == 2
    assert [s.current_version for s in store.list_processes()] == [2]


def test_saving_identical_markdown_stores_nothing_new(
    store: SqliteFtsProcessStore, docs: Any
) -> None:
    store.save(parse_process(docs.mailroom))

    result = store.save(parse_process(docs.mailroom))

    assert not result.created
    assert result.process.version == 1


def test_search_indexes_only_the_current_version(store: SqliteFtsProcessStore, docs: Any) -> None:
    store.save(parse_process(docs.plants))
    store.save(parse_process(docs.plants.replace("kitchen", "bathroom")))

    assert search_ids(store, "bathroom") == ["water-office-plants"]
    assert search_ids(store, "kitchen") == []


def test_a_paraphrased_query_finds_the_mailroom_process_first(
    store: SqliteFtsProcessStore, docs: Any
) -> None:
    for markdown in docs.all():
        store.save(parse_process(markdown))

    assert search_ids(store, "go get my delivery from the mail room")[0] == (
        "fetch-package-from-mailroom"
    )
    assert search_ids(store, "take the guest to the boardroom")[0] == (
        "escort-visitor-to-meeting-room"
    )


def test_stemming_matches_other_forms_of_a_word(store: SqliteFtsProcessStore, docs: Any) -> None:
    store.save(parse_process(docs.patrol))

    assert search_ids(store, "patrolling corridor") == ["evening-security-patrol"]


def test_queries_with_fts_syntax_characters_do_not_error(
    store: SqliteFtsProcessStore, docs: Any
) -> None:
    store.save(parse_process(docs.mailroom))
    nasty = ['"', "pack*", "-mailroom", "NEAR(mailroom package)", "(((", "AND OR NOT", "a:b ^c"]

    results = {text: search_ids(store, text) for text in nasty}

    assert results["-mailroom"] == ["fetch-package-from-mailroom"]
    assert results["NEAR(mailroom package)"] == ["fetch-package-from-mailroom"]
    assert results['"'] == []


def test_render_match_quotes_every_term() -> None:
    assert render_match(("pick up", 'we"ird', "near", "near", " ")) == (
        '"pick up" OR "we""ird" OR "near"'
    )


def test_processes_of_another_robot_are_invisible(tmp_path: Path, docs: Any) -> None:
    path = tmp_path / "shared.sqlite3"
    first = SqliteFtsProcessStore(path, "robot-1")
    second = SqliteFtsProcessStore(path, "robot-2")
    try:
        first.save(parse_process(docs.mailroom))

        assert search_ids(second, "mailroom package") == []
        assert second.list_processes() == []
        with pytest.raises(ProcessNotFoundError):
            second.get("fetch-package-from-mailroom")
        assert search_ids(first, "mailroom package") == ["fetch-package-from-mailroom"]
    finally:
        first.close()
        second.close()


def test_outcomes_count_against_the_current_version(
    store: SqliteFtsProcessStore, docs: Any
) -> None:
    store.save(parse_process(docs.mailroom))
    store.record_outcome("fetch-package-from-mailroom", False, "door closed")
    after = store.record_outcome("fetch-package-from-mailroom", True, "worked")

    assert (after.stats.successes, after.stats.failures) == (1, 1)
    notes = [record.note for record in store.recent_outcomes("fetch-package-from-mailroom")]
    assert notes == ["worked", "door closed"]

    store.save(parse_process(docs.mailroom.replace("desk 4", "desk 5")))

    assert store.get("fetch-package-from-mailroom").stats.total == 0
    assert store.get("fetch-package-from-mailroom", 1).stats.failures == 1
    assert store.recent_outcomes("fetch-package-from-mailroom") == []
    (candidate,) = store.search(build_query("mailroom"), 5)
    assert candidate.process.stats.total == 0


def test_unknown_ids_and_versions_raise_not_found(store: SqliteFtsProcessStore, docs: Any) -> None:
    store.save(parse_process(docs.mailroom))

    with pytest.raises(ProcessNotFoundError, match="process 'missing'"):
        store.get("missing")
    with pytest.raises(ProcessNotFoundError, match="version 9"):
        store.get("fetch-package-from-mailroom", 9)
    with pytest.raises(ProcessNotFoundError):
        store.record_outcome("missing", True, "")
    with pytest.raises(ProcessNotFoundError):
        store.recent_outcomes("missing")


def test_data_survives_reopening_the_file(tmp_path: Path, docs: Any) -> None:
    path = tmp_path / "memory.sqlite3"
    first = SqliteFtsProcessStore(path, "robot-1")
    first.save(parse_process(docs.mailroom))
    first.record_outcome("fetch-package-from-mailroom", True, "")
    first.close()

    reopened = SqliteFtsProcessStore(path, "robot-1")
    try:
        assert reopened.get("fetch-package-from-mailroom").stats.successes == 1
        assert search_ids(reopened, "mailroom") == ["fetch-package-from-mailroom"]
    finally:
        reopened.close()


def test_a_tiny_store_still_ranks_by_distinctive_words(
    store: SqliteFtsProcessStore, docs: Any
) -> None:
    store.save(parse_process(docs.mailroom))
    store.save(parse_process(docs.reception))

    (best, other) = store.search(build_query("package from the mailroom", synonyms=False), 5)

    assert best.process.id == "fetch-package-from-mailroom"
    assert best.relevance > other.relevance > 0


def test_concurrent_saves_from_threads_all_land(store: SqliteFtsProcessStore) -> None:
    from robot_mcp_memory.documents import render_process

    def save(index: int) -> None:
        store.save(parse_process(render_process(f"task-{index}", "T", "p", [], ["s"])))

    threads = [threading.Thread(target=save, args=(index,)) for index in range(20)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(timeout=10)

    assert len(store.list_processes()) == 20


def test_an_empty_query_or_zero_limit_returns_nothing(
    store: SqliteFtsProcessStore, docs: Any
) -> None:
    store.save(parse_process(docs.mailroom))

    assert store.search(SearchQuery(words=()), 5) == []
    assert store.search(build_query("mailroom"), 0) == []


def test_an_unreadable_database_path_is_a_store_error(tmp_path: Path) -> None:
    (tmp_path / "not-a-db").write_bytes(b"this is not sqlite" * 100)

    with pytest.raises(StoreError, match="cannot open the process store"):
        SqliteFtsProcessStore(tmp_path / "not-a-db", "robot-1")


def test_reads_on_a_closed_store_are_store_errors(tmp_path: Path) -> None:
    closed = SqliteFtsProcessStore(tmp_path / "m.sqlite3", "robot-1")
    closed.close()

    with pytest.raises(StoreError):
        closed.list_processes()


def test_robot_ids_become_single_tokens() -> None:
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
        assert conn.execute("PRAGMA user_version").fetchone() == (1,)
