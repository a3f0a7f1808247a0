"""what_happened keeps the newest max_items of the window by when each event began, reads no
more rows than that, and filters stays by place before the limit."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from robot_mcp_episodic.composition import EpisodicApp, build_app
from robot_mcp_episodic.config import EpisodicConfig
from robot_mcp_episodic.episode import ManualClock
from robot_mcp_episodic.store.base import Note, Sighting, Visit

T = 1_790_000_000.0


@pytest.fixture
def app(tmp_path: Path) -> Iterator[EpisodicApp]:
    built = build_app(
        EpisodicConfig(data_dir=tmp_path, record_raw=False),
        record_ros=False,
        clock=ManualClock(T + 200),
    )
    try:
        yield built
    finally:
        built.close()


def seen(sid: str, label: str, first: float, last: float) -> Sighting:
    return Sighting(sid, "robot-1", "office", "detect", label, first, last, place="kitchen")


def test_the_digest_ends_with_what_began_last_even_when_older_intervals_lasted_longer(
    app: EpisodicApp,
) -> None:
    # Thirteen intervals began early and lasted to the end; the plant was seen last, briefly.
    app.memory.store.save_sightings([
        *(seen(f"s-{k}", f"thing {k}", T + k, T + 150) for k in range(13)),
        seen("s-plant", "plant", T + 140, T + 141),
    ])  # fmt: skip
    app.memory.store.save_notes([Note("n-1", "robot-1", "office", T + 120, "user", "hello")])

    digest = app.memory.what_happened(start="-10m", max_items=3)

    assert [item["id"] for item in digest["items"]] == ["s-12", "n-1", "s-plant"]
    assert digest["truncated"] is True
    whole = app.memory.what_happened(start="-10m", max_items=15)
    assert len(whole["items"]) == 15
    assert whole["truncated"] is False


def test_stays_are_filtered_by_place_before_the_limit(app: EpisodicApp) -> None:
    app.memory.store.save_visits([
        Visit("v-kitchen", "robot-1", "office", "kitchen", T + 1, T + 5),
        *(Visit(f"v-{k}", "robot-1", "office", "dock", T + 10 * k, T + 10 * k + 5)
          for k in range(1, 9)),
    ])  # fmt: skip

    digest = app.memory.what_happened(start="-10m", kinds=["places"], place="kitchen", max_items=1)

    assert [item["id"] for item in digest["items"]] == ["v-kitchen"]
    assert digest["items"][0]["text"] == "was at kitchen for 4 s"
