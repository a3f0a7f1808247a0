"""The EpisodicStore contract: every test runs on SQLite and on a real PostgreSQL server."""

from __future__ import annotations

from collections.abc import Callable

from robot_mcp_episodic.store.base import EpisodicStore, Note, PoseSample, Sighting, Visit

StoreFactory = Callable[..., EpisodicStore]
T = 1_790_000_000.0


def sighting(sid: str, label: str, first: float, last: float, **extra: object) -> Sighting:
    fields: dict[str, object] = {
        "robot_id": "robot-1", "map": "office", "skill": "detect", "place": "kitchen",
        "count": 3, "best_score": 0.9, "box": {"x": 1, "y": 2, "width": 3, "height": 4},
        "x": 9.0, "y": -3.0, "yaw": 0.5,
    }  # fmt: skip
    fields.update(extra)
    return Sighting(sid, label=label, first_seen=first, last_seen=last, **fields)  # type: ignore[arg-type]


def note(nid: str, t: float, kind: str, text: str, **extra: object) -> Note:
    fields: dict[str, object] = {"robot_id": "robot-1", "map": "office"}
    fields.update(extra)
    return Note(nid, t=t, kind=kind, text=text, **fields)  # type: ignore[arg-type]


def test_a_sighting_interval_grows_by_upsert_and_keeps_its_first_seen(
    open_store: StoreFactory,
) -> None:
    store = open_store()
    store.save_sightings([sighting("s-1", "mug", T, T + 1)])

    grown = sighting("s-1", "mug", T + 99, T + 30, count=40, best_score=0.95)
    store.save_sightings([grown])

    [read] = store.sightings(T - 10, T + 100)
    assert (read.first_seen, read.last_seen, read.count, read.best_score) == (T, T + 30, 40, 0.95)
    assert read.box == {"x": 1, "y": 2, "width": 3, "height": 4}
    assert (read.robot_id, read.map, read.place) == ("robot-1", "office", "kitchen")


def test_sightings_overlapping_a_window_filtered_by_label_and_place(
    open_store: StoreFactory,
) -> None:
    store = open_store()
    store.save_sightings([
        sighting("s-1", "mug", T, T + 10),
        sighting("s-2", "mug", T + 100, T + 110, place="reception"),
        sighting("s-3", "scissors", T + 50, T + 60),
    ])  # fmt: skip

    assert [s.id for s in store.sightings(T + 5, T + 55)] == ["s-1", "s-3"]
    assert [s.id for s in store.sightings(T, T + 200, labels=["mug"])] == ["s-1", "s-2"]
    assert [s.id for s in store.sightings(T, T + 200, labels=["mug"], place="reception")] == ["s-2"]
    assert store.sightings(T, T + 200, labels=[]) == []
    newest = store.sightings(T, T + 200, newest_first=True, limit=2)
    assert [s.id for s in newest] == ["s-2", "s-3"]
    assert store.labels() == ["mug", "scissors"]
    latest = store.latest_sighting("detect", "mug")
    assert latest is not None
    assert latest.id == "s-2"
    assert store.latest_sighting("detect", "lamp") is None


def test_rows_of_another_robot_are_invisible(open_store: StoreFactory) -> None:
    mine, theirs = open_store("robot-1"), open_store("robot-2")
    theirs.save_sightings([sighting("s-9", "mug", T, T + 1, robot_id="robot-2")])
    theirs.save_notes([note("n-9", T, "scene", "a mug", robot_id="robot-2")])
    theirs.save_poses([PoseSample("robot-2", "office", T, 1.0, 2.0, 0.0)])

    assert mine.sightings(0, T + 10) == []
    assert mine.labels() == []
    assert mine.search_notes(["mug"], 0, T + 10) == []
    assert mine.pose_near(T) == (None, None)
    assert len(theirs.sightings(0, T + 10)) == 1


def test_notes_full_text_search_applies_time_and_place_before_ranking(
    open_store: StoreFactory,
) -> None:
    store = open_store()
    store.save_notes([
        note("n-1", T, "scene", "A red mug next to the coffee machine", place="kitchen"),
        note("n-2", T + 10, "user", "Please bring me the scissors", place="reception"),
        note("n-3", T + 20, "scene", "Two mugs on the meeting table", place="meeting_room"),
        note("n-4", T + 30, "robot", "I am going to the kitchen", place="dock"),
    ])  # fmt: skip

    hits = store.search_notes(["mug"], 0, T + 100)
    assert {hit.note.id for hit in hits} == {"n-1", "n-3"}  # stemming: mugs ~ mug
    assert all(hit.score >= 0 for hit in hits)
    assert [hit.score for hit in hits] == sorted((hit.score for hit in hits), reverse=True)
    assert [h.note.id for h in store.search_notes(["mug"], T + 15, T + 100)] == ["n-3"]
    assert [h.note.id for h in store.search_notes(["mug"], 0, T + 100, place="kitchen")] == ["n-1"]
    either = store.search_notes(["scissors", "coffee"], 0, T + 100)
    assert {h.note.id for h in either} == {"n-1", "n-2"}
    # Query syntax characters are plain text, never an error.
    assert {h.note.id for h in store.search_notes(['"mug" OR (*'], 0, T + 100)} <= {"n-1", "n-3"}
    assert [n.id for n in store.notes(0, T + 100, kinds=["user", "robot"])] == ["n-2", "n-4"]
    assert [n.id for n in store.notes(0, T + 100, newest_first=True, limit=1)] == ["n-4"]
    assert store.notes(0, T + 100, kinds=[]) == []


def test_saving_a_note_twice_keeps_one(open_store: StoreFactory) -> None:
    store = open_store()
    store.save_notes([note("n-1", T, "scene", "a mug")])
    store.save_notes([note("n-1", T, "scene", "a mug")])
    assert len(store.notes(0, T + 1)) == 1


def test_pose_track_reads_and_nearest_samples(open_store: StoreFactory) -> None:
    store = open_store()
    store.save_poses([
        PoseSample("robot-1", "office", T + i * 10, float(i), 0.0, 0.0, "dock" if i < 2 else None)
        for i in range(5)
    ])  # fmt: skip

    track = store.poses(T + 5, T + 35)
    assert [p.x for p in track] == [1.0, 2.0, 3.0]
    assert all(p.id is not None for p in track)
    before, after = store.pose_near(T + 12)
    assert before is not None
    assert after is not None
    assert (before.x, after.x) == (1.0, 2.0)
    assert store.pose_near(T - 1)[0] is None
    assert store.pose_near(T + 100)[1] is None


def test_delete_by_ids_and_retention_and_audit(open_store: StoreFactory) -> None:
    store = open_store()
    store.save_sightings([sighting("s-1", "mug", T, T + 1), sighting("s-2", "cup", T + 50, T + 60)])
    store.save_notes([note("n-1", T, "scene", "old"), note("n-2", T + 100, "scene", "new")])
    store.save_poses([PoseSample("robot-1", "office", T + i, 0.0, 0.0, 0.0) for i in range(3)])
    pose_ids = [p.id for p in store.poses(T, T + 1) if p.id is not None]

    deleted = store.delete(["s-1", "s-404"], ["n-1"], pose_ids)
    assert (deleted.sightings, deleted.notes, deleted.poses, deleted.total()) == (1, 1, 2, 4)
    assert store.delete_before("sightings", T + 55) == 0  # s-2 ended after the cut
    assert store.delete_before("sightings", T + 61) == 1
    assert store.delete_before("notes", T + 101) == 1
    assert store.delete_before("poses", T + 10) == 1

    store.record_audit(T + 200, {"label": "mug"}, {"sightings": 1})
    stats = store.stats()
    assert {k: v.rows for k, v in stats.kinds.items()} == {
        "sightings": 0, "poses": 0, "notes": 0, "visits": 0,
    }  # fmt: skip
    assert stats.audit == [{"t": T + 200, "request": {"label": "mug"}, "result": {"sightings": 1}}]
    assert stats.size_bytes > 0
    store.compact()


def test_stats_give_rows_and_time_span_per_kind(open_store: StoreFactory) -> None:
    store = open_store()
    store.save_sightings([sighting("s-1", "mug", T, T + 5), sighting("s-2", "mug", T + 9, T + 20)])
    stats = store.stats()
    assert stats.kinds["sightings"].rows == 2
    assert (stats.kinds["sightings"].oldest, stats.kinds["sightings"].newest) == (T + 5, T + 20)
    assert stats.kinds["notes"].oldest is None


def test_the_sightings_that_began_last_in_a_window_come_latest_start_first(
    open_store: StoreFactory,
) -> None:
    store = open_store()
    store.save_sightings([
        sighting("s-old", "mug", T - 500, T - 400),  # over before the window
        sighting("s-long", "plant", T - 300, T + 990),  # began before, still seen in it
        sighting("s-a", "mug", T + 10, T + 20),
        sighting("s-b", "cup", T + 30, T + 31, place="reception"),
        sighting("s-c", "mug", T + 50, T + 2000),  # began inside, seen long after
        sighting("s-late", "mug", T + 1500, T + 1600),  # after the window
    ])  # fmt: skip
    began = store.sightings_by_start(T, T + 1000, limit=10)
    assert [s.id for s in began] == ["s-c", "s-b", "s-a", "s-long"]
    assert [s.id for s in store.sightings_by_start(T, T + 1000, limit=2)] == ["s-c", "s-b"]
    assert [s.id for s in store.sightings_by_start(T, T + 1000, limit=4)] == [
        "s-c", "s-b", "s-a", "s-long",
    ]  # fmt: skip
    at_reception = store.sightings_by_start(T, T + 1000, place="reception", limit=10)
    assert [s.id for s in at_reception] == ["s-b"]
    assert [s.id for s in store.sightings_by_start(T + 950, T + 1000, limit=10)] == [
        "s-c", "s-long",
    ]  # fmt: skip
    assert open_store("robot-2").sightings_by_start(0, T + 9000, limit=10) == []


def test_stays_are_read_by_place_and_the_latest_arrivals_win_the_limit(
    open_store: StoreFactory,
) -> None:
    store = open_store()
    store.save_visits([
        Visit("v-1", "robot-1", "office", "dock", T - 100, T + 5),  # straddles the start
        Visit("v-2", "robot-1", "office", "kitchen", T + 10, T + 20),
        Visit("v-3", "robot-1", "office", "dock", T + 30, T + 40),
        Visit("v-4", "robot-1", "office", "kitchen", T + 50, T + 60),
    ])  # fmt: skip
    assert [v.id for v in store.visits(T, T + 100, place="dock")] == ["v-1", "v-3"]
    assert [v.id for v in store.visits(T, T + 100, place="kitchen", limit=1)] == ["v-4"]
    assert [v.id for v in store.visits(T, T + 100, limit=3)] == ["v-2", "v-3", "v-4"]
    assert [v.id for v in store.visits(T + 1, T + 35, limit=10)] == ["v-1", "v-2", "v-3"]


def test_stays_grow_by_upsert_and_are_read_by_overlap(open_store: StoreFactory) -> None:
    store = open_store()
    store.save_visits([
        Visit("v-1", "robot-1", "office", "dock", T, T + 1),
        Visit("v-2", "robot-1", "office", "kitchen", T + 3, T + 4),
        Visit("v-3", "robot-1", "office", "dock", T + 8, T + 8),
    ])  # fmt: skip
    store.save_visits([Visit("v-2", "robot-1", "office", "kitchen", T + 3, T + 5)])

    visits = store.visits(T, T + 100)
    assert [(v.place, v.arrived - T, v.departed - T) for v in visits] == [
        ("dock", 0, 1), ("kitchen", 3, 5), ("dock", 8, 8),
    ]  # fmt: skip
    assert [v.id for v in store.visits(T + 4.5, T + 100)] == ["v-2", "v-3"]
    assert [v.id for v in store.visits(T, T + 100, limit=2)] == ["v-2", "v-3"]
    assert store.delete([], [], [], ["v-1"]).visits == 1
    assert store.delete_before("visits", T + 6) == 1
    assert [v.id for v in store.visits(0, T + 100)] == ["v-3"]
    assert open_store("robot-2").visits(0, T + 100) == []
