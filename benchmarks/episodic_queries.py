"""Episodic memory: query latency with 1 h and 100 h recorded, and the index size of one busy
robot-hour.

1. Index size: one hour replayed time-compressed through the real indexer at the full rate
   (4 skills x 10 Hz detections, pose at 10 Hz, the robot driving between places half the
   time), flushed every second of robot time; the SQLite file after a clean close.
2. Latency: synthetic indexes of 1 h and 100 h (rows written directly: per hour 120 sighting
   intervals of 60 labels, the pose track of a robot driving half the time, 30 stays at named
   places, 30 notes) on SQLite; p50/p95 of last_seen, what_happened (-10m and -1h) and
   search_memory through the service, and last_seen through an in-process MCP client.

    uv run python benchmarks/episodic_queries.py [--hours 1 100] [--no-index-hour]
        # writes benchmarks/results/episodic_queries.json

The machine's load average is recorded before and after each index's measurements: on a
shared machine the p95s move with it.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import math
import os
import random
import statistics
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from mcp import Client

from robot_mcp_episodic.composition import EpisodicApp, build_app
from robot_mcp_episodic.config import EpisodicConfig
from robot_mcp_episodic.episode import ManualClock
from robot_mcp_episodic.ingest import new_id
from robot_mcp_episodic.store.base import Note, PoseSample, Sighting, Visit
from robot_mcp_episodic.store.sqlite import SqliteEpisodicStore

RESULTS = Path(__file__).parent / "results"
START = 1_790_000_000.0
LABELS = [f"{color} {thing}" for color in ("red", "blue", "green") for thing in (
    "mug", "chair", "bottle", "bag", "laptop", "plant", "box", "book", "cup", "lamp",
    "phone", "backpack", "umbrella", "keyboard", "monitor", "scissors", "parcel", "pen",
    "folder", "jacket")]  # fmt: skip
PLACES = ["dock", "reception", "kitchen", "corridor_b", "mailroom", "desk_alice", "desk_bob",
          "meeting_room"]  # fmt: skip
WORDS = ["coffee", "parcel", "visitor", "meeting", "door", "printer", "battery", "window"]


def percentiles(samples: list[float]) -> dict[str, float]:
    ordered = sorted(samples)
    return {
        "p50_ms": round(statistics.median(ordered) * 1000, 2),
        "p95_ms": round(ordered[int(len(ordered) * 0.95) - 1] * 1000, 2),
    }


def index_bytes_per_hour(work: Path) -> dict[str, Any]:
    clock = ManualClock(START)
    app = build_app(
        EpisodicConfig(data_dir=work / "hour", record_raw=False), record_ros=False, clock=clock
    )
    indexer = app.memory.indexer
    places = app.memory.places
    rng = random.Random(1)
    route = [places.position(p) for p in PLACES]
    leg, progress = 0, 0.0
    x, y = route[0]
    started = time.perf_counter()
    for tick in range(36_000):  # 10 Hz for one hour
        now = START + tick / 10
        clock.now = now
        if (tick // 600) % 2 == 0:  # drive for a minute, then stand for a minute
            (x0, y0), (x1, y1) = route[leg], route[(leg + 1) % len(route)]
            progress += 0.08 / max(0.1, math.hypot(x1 - x0, y1 - y0))
            if progress >= 1.0:
                leg, progress = (leg + 1) % len(route), 0.0
            x, y = x0 + (x1 - x0) * min(progress, 1), y0 + (y1 - y0) * min(progress, 1)
            yaw = math.atan2(y1 - y0, x1 - x0)
        else:
            yaw = 0.0
        indexer.on_pose(now, x, y, yaw)
        for skill in range(4):
            labels = [LABELS[(skill * 5 + k + tick // 900) % len(LABELS)] for k in range(3)]
            if rng.random() < 0.1:
                labels = labels[:1]
            indexer.on_detections(f"skill{skill}", now, [
                {"label": label, "score": rng.uniform(0.4, 0.95),
                 "box": {"x": 10, "y": 20, "width": 30, "height": 40}} for label in labels
            ])  # fmt: skip
        if tick % 600 == 0:
            indexer.note("scene", f"scene {tick}: a {rng.choice(WORDS)} near the {PLACES[leg]}")
        if tick % 10 == 0:
            indexer.flush()
    elapsed = time.perf_counter() - started
    stats = app.memory.store.stats()
    app.close()
    size = (work / "hour" / "episodic.sqlite3").stat().st_size
    return {
        "index_mb_per_robot_hour": round(size / 1e6, 2),
        "rows": {kind: k.rows for kind, k in stats.kinds.items()},
        "replay_s": round(elapsed, 1),
        "events": 36_000 * 5,
    }


def synthetic_index(path: Path, hours: int) -> SqliteEpisodicStore:
    store = SqliteEpisodicStore(path, "robot-1")
    rng = random.Random(hours)
    for hour in range(hours):
        base = START + hour * 3600
        sightings = []
        for _ in range(120):
            first = base + rng.uniform(0, 3500)
            sightings.append(Sighting(
                new_id("s"), "robot-1", "office", f"skill{rng.randrange(4)}",
                rng.choice(LABELS), first, first + rng.uniform(0.5, 120), rng.randrange(1, 900),
                rng.uniform(0.4, 0.95), {"x": 1, "y": 2, "width": 3, "height": 4},
                rng.uniform(0, 17), rng.uniform(-3, 10), 0.0, rng.choice(PLACES),
            ))  # fmt: skip
        poses = []
        visits = [
            Visit(new_id("v"), "robot-1", "office", PLACES[(hour * 30 + m // 2) % len(PLACES)],
                  base + m * 60, base + m * 60 + 59)
            for m in range(1, 60, 2)
        ]  # fmt: skip
        t = base
        while t < base + 3600:  # a minute driving (no named place), a minute at a place
            minute = int((t - base) // 60)
            moving = minute % 2 == 0
            place = None if moving else PLACES[(hour * 30 + minute // 2) % len(PLACES)]
            poses.append(PoseSample("robot-1", "office", t, rng.uniform(0, 17),
                                    rng.uniform(-3, 10), 0.0, place))  # fmt: skip
            t += 0.32 if moving else 10.0
        notes = [
            Note(new_id("n"), "robot-1", "office", base + rng.uniform(0, 3600),
                 rng.choice(["scene", "user", "robot"]),
                 f"{rng.choice(WORDS)} {rng.choice(LABELS)} at the {rng.choice(PLACES)}",
                 None, rng.choice(PLACES))
            for _ in range(30)
        ]  # fmt: skip
        store.save_sightings(sightings)
        store.save_poses(poses)
        store.save_notes(notes)
        store.save_visits(visits)
    return store


def timed(call: Callable[[], object], runs: int) -> dict[str, float]:
    samples = []
    for _ in range(runs):
        started = time.perf_counter()
        call()
        samples.append(time.perf_counter() - started)
    return percentiles(samples)


async def over_mcp(app: EpisodicApp, runs: int) -> dict[str, float]:
    rng = random.Random(7)
    samples = []
    async with Client(app.server) as client:
        for _ in range(runs):
            started = time.perf_counter()
            await client.call_tool("last_seen", {"query": rng.choice(LABELS)})
            samples.append(time.perf_counter() - started)
    return percentiles(samples)


def latency(work: Path, hours: int, runs: int) -> dict[str, Any]:
    started = time.perf_counter()
    store = synthetic_index(work / f"h{hours}" / "episodic.sqlite3", hours)
    built = time.perf_counter() - started
    clock = ManualClock(START + hours * 3600)
    app = build_app(
        EpisodicConfig(data_dir=work / f"h{hours}", record_raw=False),
        store=store, record_ros=False, clock=clock,
    )  # fmt: skip
    memory = app.memory
    rng = random.Random(3)
    load_before = [round(x, 2) for x in os.getloadavg()]
    result = {
        "rows": {kind: k.rows for kind, k in store.stats().kinds.items()},
        "build_s": round(built, 1),
        "last_seen": timed(lambda: memory.last_seen(rng.choice(LABELS)), runs),
        "last_seen_place": timed(
            lambda: memory.last_seen(rng.choice(LABELS), place=rng.choice(PLACES)), runs
        ),
        "what_happened_10m": timed(lambda: memory.what_happened("-10m"), runs),
        "what_happened_1h": timed(lambda: memory.what_happened("-1h"), runs),
        "search_memory": timed(lambda: memory.search_memory(rng.choice(WORDS)), runs),
        "search_memory_label_words": timed(
            lambda: memory.search_memory(rng.choice(LABELS), start="-24h"), runs
        ),
        "last_seen_over_mcp": asyncio.run(over_mcp(app, max(20, runs // 4))),
        "load_average_before": load_before,
        "load_average_after": [round(x, 2) for x in os.getloadavg()],
    }
    app.close()
    return result


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--hours", type=int, nargs="+", default=[1, 100])
    parser.add_argument("--runs", type=int, default=200)
    parser.add_argument(
        "--no-index-hour", action="store_true", help="skip the index-size replay (latency only)"
    )
    args = parser.parse_args()
    work = Path(tempfile.mkdtemp(prefix="episodic-queries-"))
    result: dict[str, Any] = {}
    if not args.no_index_hour:
        result["index_hour"] = hour = index_bytes_per_hour(work)
        print(
            f"index per busy robot-hour: {hour['index_mb_per_robot_hour']} MB (goal <= 5), "
            f"rows {hour['rows']}, {hour['events']} events replayed in {hour['replay_s']} s"
        )
    for hours in args.hours:
        result[f"{hours}h"] = measured = latency(work, hours, args.runs)
        print(
            f"{hours} h recorded, rows {measured['rows']} (built in {measured['build_s']} s), "
            f"load {measured['load_average_before']} -> {measured['load_average_after']}:"
        )
        for name, value in measured.items():
            if isinstance(value, dict) and "p50_ms" in value:
                print(f"  {name:28s} p50 {value['p50_ms']:7.2f} ms   p95 {value['p95_ms']:7.2f} ms")
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / "episodic_queries.json").write_text(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
