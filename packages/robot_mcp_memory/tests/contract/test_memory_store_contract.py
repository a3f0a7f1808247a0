"""The ProcessStore contract: every test runs on SQLite and on a real PostgreSQL server."""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any

import pytest

from robot_mcp_memory.documents import parse_process, render_process
from robot_mcp_memory.query import build_query
from robot_mcp_memory.service import ProcessMemory
from robot_mcp_memory.store.base import ProcessNotFoundError, ProcessStore, SearchQuery

StoreFactory = Callable[..., ProcessStore]
MAILROOM_ID = "fetch-package-from-mailroom"


def search_ids(store: ProcessStore, text: str, limit: int = 10) -> list[str]:
    return [candidate.process.id for candidate in store.search(build_query(text), limit)]


def run_together(*work: Callable[[], object], timeout_s: float = 60.0) -> None:
    """Run callables in threads released at once; re-raise the first failure."""
    start = threading.Barrier(len(work))
    failures: list[BaseException] = []

    def run(job: Callable[[], object]) -> None:
        try:
            start.wait(timeout_s)
            job()
        except BaseException as exc:
            failures.append(exc)

    threads = [threading.Thread(target=run, args=(job,)) for job in work]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(timeout_s)
    assert not any(thread.is_alive() for thread in threads), "a concurrent call hung"
    if failures:
        raise failures[0]


# -- one robot --------------------------------------------------------------------------------


def test_saving_a_new_id_stores_version_one(open_store: StoreFactory, docs: Any) -> None:
    store = open_store()

    result = store.save(parse_process(docs.mailroom))

    assert result.created
    assert (result.process.version, result.process.current_version) == (1, 1)
    assert result.process.saved_by == "robot-1"
    assert store.get(MAILROOM_ID).markdown == parse_process(docs.mailroom).markdown


def test_saving_the_same_id_again_keeps_the_old_version(
    open_store: StoreFactory, docs: Any
) -> None:
    store = open_store()
    store.save(parse_process(docs.mailroom))

    result = store.save(parse_process(docs.mailroom.replace("desk 4", "desk 7")))

    assert result.created
    assert result.process.version == 2
    assert "desk 7" in store.get(MAILROOM_ID).markdown
    old = store.get(MAILROOM_ID, version=1)
    assert "desk 4" in old.markdown
    assert old.current_version == 2
    assert [summary.current_version for summary in store.list_processes()] == [2]


def test_saving_identical_markdown_stores_nothing_new(open_store: StoreFactory, docs: Any) -> None:
    store = open_store()
    store.save(parse_process(docs.mailroom))

    result = store.save(parse_process(docs.mailroom))

    assert not result.created
    assert result.process.version == 1


def test_search_indexes_only_the_current_version(open_store: StoreFactory, docs: Any) -> None:
    store = open_store()
    store.save(parse_process(docs.plants))
    store.save(parse_process(docs.plants.replace("kitchen", "bathroom")))

    assert search_ids(store, "bathroom") == ["water-office-plants"]
    assert search_ids(store, "kitchen") == []


def test_a_paraphrased_query_finds_the_right_process_first(
    open_store: StoreFactory, docs: Any
) -> None:
    store = open_store()
    for markdown in docs.all():
        store.save(parse_process(markdown))

    assert search_ids(store, "go get my delivery from the mail room")[0] == MAILROOM_ID
    assert search_ids(store, "take the guest to the boardroom")[0] == (
        "escort-visitor-to-meeting-room"
    )


def test_stemming_matches_other_forms_of_a_word(open_store: StoreFactory, docs: Any) -> None:
    store = open_store()
    store.save(parse_process(docs.patrol))

    assert search_ids(store, "patrolling corridor") == ["evening-security-patrol"]


def test_query_syntax_characters_are_plain_text(open_store: StoreFactory, docs: Any) -> None:
    store = open_store()
    store.save(parse_process(docs.mailroom))
    nasty = ['"', "pack*", "-mailroom", "NEAR(mailroom package)", "(((", "AND OR NOT", "a:b ^c"]
    nasty += ["mailroom' OR 1=1 --", "!mailroom & | <->", "or or or"]

    results = {text: search_ids(store, text) for text in nasty}

    assert results["-mailroom"] == [MAILROOM_ID]
    assert results["NEAR(mailroom package)"] == [MAILROOM_ID]
    assert results["mailroom' OR 1=1 --"] == [MAILROOM_ID]
    assert results["!mailroom & | <->"] == [MAILROOM_ID]
    assert results['"'] == []


def test_outcomes_count_against_the_current_version(open_store: StoreFactory, docs: Any) -> None:
    store = open_store()
    store.save(parse_process(docs.mailroom))
    store.record_outcome(MAILROOM_ID, False, "door closed")
    after = store.record_outcome(MAILROOM_ID, True, "worked")

    assert (after.stats.successes, after.stats.failures) == (1, 1)
    assert after.robot_stats == after.stats
    records = store.recent_outcomes(MAILROOM_ID)
    assert [(record.note, record.robot_id) for record in records] == [
        ("worked", "robot-1"),
        ("door closed", "robot-1"),
    ]

    store.save(parse_process(docs.mailroom.replace("desk 4", "desk 5")))

    assert store.get(MAILROOM_ID).stats.total == 0
    assert store.get(MAILROOM_ID, 1).stats.failures == 1
    assert store.recent_outcomes(MAILROOM_ID) == []
    (candidate,) = store.search(build_query("mailroom"), 5)
    assert candidate.process.stats.total == 0


def test_unknown_ids_and_versions_raise_not_found(open_store: StoreFactory, docs: Any) -> None:
    store = open_store()
    store.save(parse_process(docs.mailroom))

    with pytest.raises(ProcessNotFoundError, match="process 'missing'"):
        store.get("missing")
    with pytest.raises(ProcessNotFoundError, match="version 9"):
        store.get(MAILROOM_ID, 9)
    with pytest.raises(ProcessNotFoundError):
        store.record_outcome("missing", True, "")
    with pytest.raises(ProcessNotFoundError):
        store.recent_outcomes("missing")


def test_data_survives_reopening_the_store(open_store: StoreFactory, docs: Any) -> None:
    first = open_store()
    first.save(parse_process(docs.mailroom))
    first.record_outcome(MAILROOM_ID, True, "")
    first.close()

    reopened = open_store()

    assert reopened.get(MAILROOM_ID).stats.successes == 1
    assert search_ids(reopened, "mailroom") == [MAILROOM_ID]


def test_a_tiny_store_still_ranks_by_distinctive_words(open_store: StoreFactory, docs: Any) -> None:
    store = open_store()
    store.save(parse_process(docs.mailroom))
    store.save(parse_process(docs.reception))

    (best, other) = store.search(build_query("package from the mailroom", synonyms=False), 5)

    assert best.process.id == MAILROOM_ID
    assert best.relevance > other.relevance > 0


ESPRESSO_ID = "refill-espresso-machine"


def save_robot_patrols_and_espresso(store: ProcessStore) -> None:
    """Eight processes about the robot's patrols ("robot" in every title, task pattern, tag and
    step) and one whose only word of the query, "espresso", is in one step."""
    for place in ("lobby", "garage", "lab", "gym", "roof", "archive", "studio", "clinic"):
        store.save(
            parse_process(
                render_process(
                    f"robot-patrol-{place}",
                    f"Robot patrol of the {place}",
                    f"the robot patrols the {place} and the robot reports",
                    ["robot", "patrol"],
                    [f"the robot drives to the {place}", "the robot looks around"],
                )
            )
        )
    store.save(
        parse_process(
            render_process(
                ESPRESSO_ID,
                "Refill the coffee machine",
                "fill the kitchen's coffee machine with beans and water",
                ["kitchen", "coffee"],
                ["navigate_to(kitchen)", "open the hopper of the espresso maker", "pour beans"],
            )
        )
    )


def test_a_rare_word_outranks_a_common_word_that_many_processes_share(
    open_store: StoreFactory,
) -> None:
    store = open_store()
    save_robot_patrols_and_espresso(store)

    ranked = store.search(build_query("robot espresso", synonyms=False), 10)

    assert ranked[0].process.id == ESPRESSO_ID
    assert len(ranked) == 9


def test_a_word_most_processes_share_weighs_less_than_a_rare_word(open_store: StoreFactory) -> None:
    store = open_store()
    save_robot_patrols_and_espresso(store)

    (alone,) = store.search(build_query("espresso", synonyms=False), 10)
    with_common = store.search(build_query("robot espresso", synonyms=False), 10)[0]
    (common_only, *_) = store.search(build_query("robot", synonyms=False), 10)

    assert with_common.process.id == alone.process.id == ESPRESSO_ID
    assert with_common.relevance == pytest.approx(alone.relevance)  # no "robot" in it
    assert alone.relevance > 2 * common_only.relevance


async def test_find_processes_puts_the_rare_word_first_among_many_common_ones(
    open_store: StoreFactory,
) -> None:
    store = open_store()
    save_robot_patrols_and_espresso(store)

    found = await ProcessMemory(store).find("can the robot make me an espresso", k=3)

    assert found["results"][0]["id"] == ESPRESSO_ID


def test_an_empty_query_or_zero_limit_returns_nothing(open_store: StoreFactory, docs: Any) -> None:
    store = open_store()
    store.save(parse_process(docs.mailroom))

    assert store.search(SearchQuery(words=()), 5) == []
    assert store.search(build_query("mailroom"), 0) == []


def test_listing_shows_the_newest_first_with_counts(open_store: StoreFactory, docs: Any) -> None:
    store = open_store()
    store.save(parse_process(docs.plants))
    store.save(parse_process(docs.patrol))
    store.record_outcome("water-office-plants", True, "")

    listed = store.list_processes()

    assert [summary.id for summary in listed] == ["evening-security-patrol", "water-office-plants"]
    assert listed[1].stats.successes == 1
    assert listed[1].saved_by == "robot-1"


def test_concurrent_saves_of_different_ids_all_land(open_store: StoreFactory) -> None:
    store = open_store()

    def saver(index: int) -> Callable[[], object]:
        document = parse_process(render_process(f"task-{index}", "T", "p", [], ["s"]))
        return lambda: store.save(document)

    run_together(*(saver(index) for index in range(12)))

    assert len(store.list_processes()) == 12


# -- fleet ------------------------------------------------------------------------------------


def test_a_robot_finds_what_another_robot_of_the_fleet_saved(
    open_store: StoreFactory, docs: Any
) -> None:
    robot_a = open_store("robot-a", "fleet")
    robot_b = open_store("robot-b", "fleet")
    robot_a.save(parse_process(docs.mailroom))

    (found,) = robot_b.search(build_query("parcel in the post room"), 5)

    assert found.process.id == MAILROOM_ID
    assert found.process.saved_by == "robot-a"
    assert [summary.id for summary in robot_b.list_processes()] == [MAILROOM_ID]


def test_outcomes_are_recorded_per_robot(open_store: StoreFactory, docs: Any) -> None:
    robot_a = open_store("robot-a", "fleet")
    robot_b = open_store("robot-b", "fleet")
    robot_a.save(parse_process(docs.mailroom))
    robot_a.record_outcome(MAILROOM_ID, True, "a fine")
    robot_b.record_outcome(MAILROOM_ID, False, "b door closed")
    robot_b.record_outcome(MAILROOM_ID, True, "b fine")

    seen_by_a = robot_a.get(MAILROOM_ID)
    seen_by_b = robot_b.get(MAILROOM_ID)

    assert (seen_by_a.stats.successes, seen_by_a.stats.failures) == (2, 1)
    assert (seen_by_a.robot_stats.successes, seen_by_a.robot_stats.failures) == (1, 0)
    assert (seen_by_b.robot_stats.successes, seen_by_b.robot_stats.failures) == (1, 1)
    assert [record.robot_id for record in robot_a.recent_outcomes(MAILROOM_ID)] == [
        "robot-b",
        "robot-b",
        "robot-a",
    ]


def test_robot_visibility_keeps_processes_to_their_robot(
    open_store: StoreFactory, docs: Any
) -> None:
    robot_a = open_store("robot-a", "robot")
    robot_b = open_store("robot-b", "robot")
    fleet = open_store("robot-c", "fleet")
    robot_a.save(parse_process(docs.mailroom))

    assert search_ids(robot_b, "mailroom package") == []
    assert search_ids(fleet, "mailroom package") == []
    assert robot_b.list_processes() == []
    with pytest.raises(ProcessNotFoundError):
        robot_b.get(MAILROOM_ID)
    assert search_ids(robot_a, "mailroom package") == [MAILROOM_ID]


async def test_ranking_prefers_success_on_this_robot_then_across_the_fleet(
    open_store: StoreFactory,
) -> None:
    robot_a = open_store("robot-a", "fleet")
    robot_b = open_store("robot-b", "fleet")
    twins = [
        render_process(f"deliver-mail-{side}", "Deliver the mail", "deliver mail", [], ["go"])
        for side in ("east", "west")
    ]
    untried = render_process("deliver-mail-north", "Deliver the mail", "deliver mail", [], ["go"])
    for markdown in [*twins, untried]:
        robot_a.save(parse_process(markdown))
    robot_a.record_outcome("deliver-mail-east", True, "")
    robot_b.record_outcome("deliver-mail-west", True, "")

    on_a = await ProcessMemory(robot_a).find("deliver the mail", k=3)
    on_b = await ProcessMemory(robot_b).find("deliver the mail", k=3)

    assert [result["id"] for result in on_a["results"]] == [
        "deliver-mail-east",
        "deliver-mail-west",
        "deliver-mail-north",
    ]
    assert [result["id"] for result in on_b["results"]] == [
        "deliver-mail-west",
        "deliver-mail-east",
        "deliver-mail-north",
    ]


def test_concurrent_saves_of_one_id_keep_a_consistent_version_history(
    open_store: StoreFactory, docs: Any
) -> None:
    robots = [open_store("robot-a", "fleet"), open_store("robot-b", "fleet")]
    markdowns = {
        (robot.robot_id, index): docs.mailroom.replace("desk 4", f"desk {robot.robot_id}-{index}")
        for robot in robots
        for index in range(6)
    }

    def saver(robot: ProcessStore, markdown: str) -> Callable[[], object]:
        return lambda: robot.save(parse_process(markdown))

    run_together(
        *(saver(robots[robot_id == "robot-b"], text) for (robot_id, _), text in markdowns.items())
    )

    current = robots[0].get(MAILROOM_ID)
    history = [robots[1].get(MAILROOM_ID, version) for version in range(1, 13)]
    assert current.version == current.current_version == 12
    assert current.markdown == history[-1].markdown
    assert sorted(version.markdown for version in history) == sorted(markdowns.values())
    by_robot = {version.markdown: version.saved_by for version in history}
    assert all(by_robot[text] == robot_id for (robot_id, _), text in markdowns.items())
    with pytest.raises(ProcessNotFoundError):
        robots[0].get(MAILROOM_ID, 13)
    (found,) = robots[1].search(build_query("mailroom"), 5)
    assert found.process.version == 12


def test_concurrent_identical_saves_store_one_version(open_store: StoreFactory, docs: Any) -> None:
    robots = [open_store("robot-a", "fleet"), open_store("robot-b", "fleet")]
    document = parse_process(docs.mailroom)
    results: list[bool] = []

    run_together(
        *(lambda robot=robot: results.append(robot.save(document).created) for robot in robots)
    )

    assert sorted(results) == [False, True]
    assert robots[0].get(MAILROOM_ID).current_version == 1


def test_concurrent_outcomes_from_two_robots_all_count(open_store: StoreFactory, docs: Any) -> None:
    robots = [open_store("robot-a", "fleet"), open_store("robot-b", "fleet")]
    robots[0].save(parse_process(docs.mailroom))

    run_together(
        *(
            lambda robot=robot, index=index: robot.record_outcome(MAILROOM_ID, index % 2 == 0, "")
            for robot in robots
            for index in range(5)
        )
    )

    stats = robots[0].get(MAILROOM_ID)
    assert (stats.stats.successes, stats.stats.failures) == (6, 4)
    assert stats.robot_stats.total == 5
