from pathlib import Path
from typing import Any

import pytest

from robot_mcp_memory.composition import build_memory
from robot_mcp_memory.config import MemoryConfig
from robot_mcp_memory.documents import render_process
from robot_mcp_memory.embeddings import EmbeddingReranker, FakeEmbedder
from robot_mcp_memory.service import MAX_NOTE_CHARS, MemoryServiceError, ProcessMemory
from robot_mcp_memory.store.base import StoreError
from robot_mcp_memory.store.fake import FakeProcessStore


@pytest.fixture
def store() -> FakeProcessStore:
    return FakeProcessStore()


@pytest.fixture
def memory(store: FakeProcessStore) -> ProcessMemory:
    return ProcessMemory(store, timeout_s=2.0)


async def error_of(awaitable: Any) -> MemoryServiceError:
    with pytest.raises(MemoryServiceError) as caught:
        await awaitable
    return caught.value


async def test_a_saved_process_is_found_with_its_markdown(memory: ProcessMemory, docs: Any) -> None:
    saved = await memory.save(docs.mailroom)

    found = await memory.find("mailroom package")

    assert saved == {
        "id": "fetch-package-from-mailroom",
        "version": 1,
        "created": True,
        "title": "Fetch a package from the mailroom",
        "message": "saved as a new process",
    }
    (result,) = found["results"]
    assert result["id"] == "fetch-package-from-mailroom"
    assert result["markdown"].startswith("---\nid: fetch-package-from-mailroom")
    assert (
        result["task_pattern"] == "bring a package from the mailroom to the person who asked for it"
    )
    assert result["score"] > 0
    assert result["outcome_boost"] == 1.0


async def test_saving_again_reports_the_new_version_and_how_to_read_old_ones(
    memory: ProcessMemory, docs: Any
) -> None:
    await memory.save(docs.mailroom)

    unchanged = await memory.save(docs.mailroom)
    changed = await memory.save(docs.mailroom.replace("desk 4", "desk 9"))
    old = await memory.get("fetch-package-from-mailroom", 1)

    assert unchanged["created"] is False
    assert "nothing new stored" in unchanged["message"]
    assert changed["version"] == 2
    assert "get_process(id, version)" in changed["message"]
    assert "desk 4" in old["markdown"]
    assert old["current_version"] == 2


async def test_a_bad_document_is_rejected_naming_its_problems(memory: ProcessMemory) -> None:
    error = await error_of(memory.save("---\nid: Not A Slug\n---\n## Steps\n1. a\n"))

    assert error.code == "invalid_document"
    assert "must be a slug" in error.detail
    assert "missing section '## Operator notes'" in error.detail
    assert error.detail.endswith("call save_process again with the whole document.")


async def test_recorded_outcomes_change_the_ranking(tmp_path: Path, docs: Any) -> None:
    memory = build_memory(MemoryConfig(db_path=tmp_path / "m.sqlite3"))
    for markdown in docs.all():
        await memory.save(markdown)
    query = "bring me the parcel that arrived"

    before = [result["id"] for result in (await memory.find(query))["results"]]
    for _ in range(3):
        await memory.record_outcome(before[0], False, "the door was locked")
    await memory.record_outcome(before[1], True, "worked fine")
    after = [result["id"] for result in (await memory.find(query))["results"]]

    assert set(before[:2]) == {"collect-parcel-at-reception", "fetch-package-from-mailroom"}
    assert after[:2] == [before[1], before[0]]
    memory.store.close()


async def test_record_outcome_reports_counts_and_get_shows_recent_notes(
    memory: ProcessMemory, docs: Any
) -> None:
    await memory.save(docs.plants)

    recorded = await memory.record_outcome("water-office-plants", False, "  can was empty  ")
    details = await memory.get("water-office-plants")

    assert recorded["failures"] == 1
    assert recorded["recorded"] is True
    assert details["recent_outcomes"][0]["note"] == "can was empty"
    assert details["recent_outcomes"][0]["success"] is False


async def test_unknown_ids_are_not_found_errors_with_a_hint(memory: ProcessMemory) -> None:
    error = await error_of(memory.record_outcome("nope", True, ""))

    assert error.code == "not_found"
    assert error.detail.startswith(
        "no process 'nope' visible to robot 'robot-1' (robot visibility)"
    )
    assert "list_processes" in error.detail


async def test_argument_limits_are_invalid_argument_errors(memory: ProcessMemory) -> None:
    assert (await error_of(memory.find("x", k=0))).code == "invalid_argument"
    assert (await error_of(memory.find("x" * 5000))).code == "invalid_argument"
    assert (await error_of(memory.record_outcome("x", True, "n" * (MAX_NOTE_CHARS + 1)))).code == (
        "invalid_argument"
    )
    assert (await error_of(memory.list_processes(limit=0))).code == "invalid_argument"


async def test_a_query_without_words_finds_nothing_without_searching(
    memory: ProcessMemory, store: FakeProcessStore, docs: Any
) -> None:
    await memory.save(docs.mailroom)

    assert (await memory.find('"*" - ()'))["results"] == []
    assert store.searches == []


async def test_the_candidate_pool_is_what_the_store_is_asked_for(
    store: FakeProcessStore, docs: Any
) -> None:
    memory = ProcessMemory(store, candidate_pool=7)
    await memory.save(docs.mailroom)

    await memory.find("mailroom", k=3)
    await memory.find("mailroom", k=12)

    assert [limit for _, limit in store.searches] == [7, 12]


async def test_a_failing_store_is_a_store_unavailable_error(
    memory: ProcessMemory, store: FakeProcessStore
) -> None:
    store.fail_with = StoreError("disk I/O error")

    error = await error_of(memory.list_processes())

    assert error.code == "store_unavailable"
    assert "disk I/O error" in error.detail


async def test_a_slow_store_is_a_timeout_error(store: FakeProcessStore) -> None:
    store.delay_s = 0.5
    memory = ProcessMemory(store, timeout_s=0.05)

    error = await error_of(memory.list_processes())

    assert error.code == "timeout"
    assert "0.05 s" in error.detail


async def test_list_pages_through_processes(memory: ProcessMemory) -> None:
    for index in range(5):
        await memory.save(render_process(f"task-{index}", f"Task {index}", "p", [], ["s"]))

    page = await memory.list_processes(limit=2, offset=1)

    assert page["total"] == 5
    assert page["robot_id"] == "robot-1"
    assert len(page["processes"]) == 2
    assert set(page["processes"][0]) == {
        "id",
        "title",
        "task_pattern",
        "tags",
        "current_version",
        "saved_by",
        "successes",
        "failures",
        "robot_successes",
        "robot_failures",
        "updated_at",
    }


async def test_the_reranker_reorders_candidates(store: FakeProcessStore, docs: Any) -> None:
    embedder = FakeEmbedder({"visitor": ["visitor", "guest", "escort", "meeting"]})
    memory = ProcessMemory(store, reranker=EmbeddingReranker(embedder, weight=0.9))
    await memory.save(docs.mailroom)
    await memory.save(docs.escort)

    found = await memory.find("navigate_to the guest")

    assert found["results"][0]["id"] == "escort-visitor-to-meeting-room"
    assert embedder.calls


async def test_synonym_settings_shape_the_store_query(store: FakeProcessStore, docs: Any) -> None:
    await store_and_find(ProcessMemory(store, concept_weight=1.5), docs, "bring the parcel")
    await store_and_find(ProcessMemory(store, synonyms=False), docs, "bring the parcel")

    (weighted, _), (plain, _) = store.searches
    assert weighted.concepts == ("synfetch", "synpackage")
    assert weighted.concept_weight == 1.5
    assert plain.concepts == ()


async def store_and_find(memory: ProcessMemory, docs: Any, query: str) -> None:
    await memory.save(docs.mailroom)
    await memory.find(query)
