"""The indexer: sighting intervals, absence evidence, pose downsampling, notes, flushing."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import pytest

from robot_mcp_episodic.ingest import Indexer, IndexRules
from robot_mcp_episodic.places import Places
from robot_mcp_episodic.store.base import EpisodicStore, StoreError
from robot_mcp_episodic.store.sqlite import SqliteEpisodicStore

T = 1_790_000_000.0


def det(label: str, score: float = 0.8, x: int = 10) -> dict[str, Any]:
    return {"label": label, "score": score, "box": {"x": x, "y": 0, "width": 5, "height": 5}}


@pytest.fixture
def indexer(sqlite_store: EpisodicStore, places: Places) -> Indexer:
    return Indexer(sqlite_store, places, IndexRules(gap_s=10.0), clock=lambda: T)


def test_a_continuous_sighting_is_one_interval_with_the_best_box(
    indexer: Indexer, sqlite_store: EpisodicStore
) -> None:
    indexer.on_pose(T, 9.0, -3.0, 0.0)
    for i, score in enumerate([0.5, 0.9, 0.7]):
        indexer.on_detections("detect", T + i, [det("mug", score, x=i), det("mug", 0.1)])
    indexer.flush()

    [s] = sqlite_store.sightings(0, T + 100)
    assert (s.first_seen, s.last_seen, s.count, s.best_score) == (T, T + 2, 3, 0.9)
    assert s.box == {"x": 1, "y": 0, "width": 5, "height": 5}
    assert (s.place, s.x, s.y, s.map, s.robot_id) == ("kitchen", 9.0, -3.0, "office", "robot-1")


def test_a_re_sighting_after_a_gap_starts_a_new_interval_and_keeps_the_first(
    indexer: Indexer, sqlite_store: EpisodicStore
) -> None:
    indexer.on_detections("detect", T, [det("mug")])
    indexer.on_detections("detect", T + 5, [det("mug")])
    indexer.on_detections("detect", T + 30, [det("mug")])
    indexer.flush()

    intervals = sqlite_store.sightings(0, T + 100)
    assert [(s.first_seen, s.last_seen) for s in intervals] == [(T, T + 5), (T + 30, T + 30)]


def test_another_place_starts_a_new_interval(indexer: Indexer, sqlite_store: EpisodicStore) -> None:
    indexer.on_pose(T, 9.0, -3.0, 0.0)
    indexer.on_detections("detect", T, [det("mug")])
    indexer.on_pose(T + 1, 4.0, 1.5, 0.0)
    indexer.on_detections("detect", T + 2, [det("mug")])
    indexer.flush()
    assert [s.place for s in sqlite_store.sightings(0, T + 100)] == ["kitchen", "reception"]


def test_looking_again_at_the_place_without_the_label_records_absence(
    indexer: Indexer, sqlite_store: EpisodicStore
) -> None:
    indexer.on_pose(T, 9.0, -3.0, 0.0)
    indexer.on_detections("detect", T, [det("mug"), det("kettle")])
    indexer.on_detections("detect", T + 3, [det("kettle")])  # within the gap: not yet absent
    indexer.on_detections("other", T + 20, [])  # another skill looking proves nothing
    indexer.on_pose(T + 25, 4.0, 1.5, 0.0)
    indexer.on_detections("detect", T + 26, [])  # elsewhere: proves nothing about the kitchen
    indexer.on_pose(T + 30, 9.0, -3.0, 0.0)
    indexer.on_detections("detect", T + 31, [det("kettle")])
    indexer.on_detections("detect", T + 32, [])
    indexer.flush()

    mug = sqlite_store.latest_sighting("detect", "mug")
    assert mug is not None
    assert mug.absent_since == T + 31
    kettle = sqlite_store.sightings(0, T + 100, labels=["kettle"])
    assert all(k.absent_since is None for k in kettle)


def test_an_interval_continues_across_a_restart(tmp_path: Path, places: Places) -> None:
    store = SqliteEpisodicStore(tmp_path / "i.sqlite3", "robot-1")
    first = Indexer(store, places)
    first.on_detections("detect", T, [det("mug")])
    first.flush()
    second = Indexer(store, places)  # a new process on the same index
    second.on_detections("detect", T + 4, [det("mug")])
    second.on_detections("detect", T + 60, [det("mug")])
    second.flush()
    assert [(s.first_seen, s.last_seen, s.count) for s in store.sightings(0, T + 100)] == [
        (T, T + 4, 2),
        (T + 60, T + 60, 1),
    ]
    store.close()


def test_the_pose_track_is_downsampled(indexer: Indexer, sqlite_store: EpisodicStore) -> None:
    indexer.on_pose(T, 0.0, 0.0, 0.0)  # kept: first
    indexer.on_pose(T + 1, 0.1, 0.0, 0.0)  # dropped
    indexer.on_pose(T + 2, 0.26, 0.0, 0.0)  # kept: moved 0.26 m
    indexer.on_pose(T + 3, 0.26, 0.0, math.radians(10))  # dropped: turned 10°
    indexer.on_pose(T + 4, 0.26, 0.0, math.radians(16))  # kept: turned 16°
    indexer.on_pose(T + 13, 0.26, 0.0, math.radians(16))  # dropped: 9 s still
    indexer.on_pose(T + 14, 0.26, 0.0, math.radians(16))  # kept: 10 s
    indexer.on_pose(T + 15, 0.26, 0.0, math.radians(-170))  # kept: turned across ±180°
    indexer.flush()
    assert [p.t - T for p in sqlite_store.poses(0, T + 100)] == [0, 2, 4, 14, 15]
    assert indexer.last_write["pose"] == T + 15


def test_skill_outputs_become_notes_when_they_change(
    indexer: Indexer, sqlite_store: EpisodicStore
) -> None:
    indexer.on_output("describe", "description", T, "A quiet kitchen")
    indexer.on_output("describe", "description", T + 1, "A quiet kitchen")
    indexer.on_output("door", "open", T + 2, {"open": True})
    indexer.flush()
    notes = sqlite_store.notes(0, T + 100)
    assert [(n.kind, n.text) for n in notes] == [
        ("scene", "describe description: A quiet kitchen"),
        ("observation", 'door open: {"open":true}'),
    ]


def test_the_objects_a_scene_describer_lists_are_sightings_where_the_robot_was(
    indexer: Indexer, sqlite_store: EpisodicStore
) -> None:
    indexer.on_pose(T, 9.0, -3.0, 0.0)  # the kitchen
    indexer.on_output("scene", "scene_objects", T, ["red mug", "kettle"])
    indexer.on_output("scene", "scene_objects", T + 10, ["red mug"])  # the kettle is gone
    indexer.flush()
    seen = {s.label: s for s in sqlite_store.sightings(0, T + 100)}
    assert set(seen) == {"red mug", "kettle"}
    assert (seen["red mug"].place, seen["red mug"].skill) == ("kitchen", "scene")
    assert (seen["red mug"].first_seen, seen["red mug"].last_seen) == (T, T + 10)
    assert seen["kettle"].absent_since == T + 10
    assert [n.kind for n in sqlite_store.notes(0, T + 100)] == ["observation", "observation"]


def test_a_failed_flush_keeps_the_rows_for_the_next_one(
    indexer: Indexer, sqlite_store: EpisodicStore, monkeypatch: pytest.MonkeyPatch
) -> None:
    indexer.on_detections("detect", T, [det("mug")])
    indexer.note("user", "hello")
    indexer.on_pose(T, 0.0, 0.0, 0.0)

    def broken(*_: object) -> None:
        raise StoreError("disk full")

    monkeypatch.setattr(sqlite_store, "save_poses", broken)
    with pytest.raises(StoreError):
        indexer.flush()
    monkeypatch.undo()
    assert indexer.flush() == 4  # the sighting, the note, the pose and the stay
    assert len(sqlite_store.notes(0, T + 1)) == 1
    assert len(sqlite_store.poses(0, T + 1)) == 1


def test_a_sighting_before_the_first_pose_takes_the_place_once_known(
    indexer: Indexer, sqlite_store: EpisodicStore
) -> None:
    indexer.on_detections("detect", T, [det("mug")])
    indexer.flush()
    indexer.on_pose(T + 1, 9.0, -3.0, 0.5)
    indexer.on_detections("detect", T + 2, [det("mug")])
    indexer.flush()
    [s] = sqlite_store.sightings(0, T + 100)
    assert (s.first_seen, s.place, s.x, s.y, s.yaw) == (T, "kitchen", 9.0, -3.0, 0.5)
