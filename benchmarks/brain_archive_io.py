"""The mission archive under a burst (issue 39): what a mission's page waits for.

In process, on a fresh SQLite file: 20 sequential ``append_event`` calls (a mission's log
lines), then a read (``events``, what ``GET /api/agent/missions/{id}`` does) issued while 20
more appends are queued. Before issue 39 each statement opened, committed and closed its own
connection behind one lock, so the read waited for every queued write.

Run: ``uv run python benchmarks/brain_archive_io.py [--rounds 20]``.
Writes benchmarks/results/brain_archive_io.json.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import tempfile
import time
from pathlib import Path
from typing import Any

from robot_voice_chat.agent.archive import SqliteMissionArchive
from robot_voice_chat.socket_events import MissionEventLine

RESULTS = Path(__file__).with_name("results")


def percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, max(0, round(q * (len(ordered) - 1))))]


def summary(values: list[float]) -> dict[str, Any]:
    ms = [v * 1000 for v in values]
    return {"n": len(ms), "p50_ms": round(percentile(ms, 0.5), 2), "max_ms": round(max(ms), 2)}


async def round_trip(directory: Path) -> tuple[float, float]:
    archive = SqliteMissionArchive(directory / "missions.sqlite3")
    line = MissionEventLine(mission_id="m-1", kind="say", text="x" * 200, ts=time.time())
    await archive.append_event(line)
    started = time.monotonic()
    for _ in range(20):
        await archive.append_event(line)
    appends = time.monotonic() - started
    writes = [asyncio.create_task(archive.append_event(line)) for _ in range(20)]
    await asyncio.sleep(0)
    started = time.monotonic()
    await archive.events("m-1")
    read = time.monotonic() - started
    await asyncio.gather(*writes)
    return appends, read


async def run(rounds: int) -> dict[str, Any]:
    appends, reads = [], []
    load = os.getloadavg()
    for _ in range(rounds):
        with tempfile.TemporaryDirectory() as scratch:
            a, r = await round_trip(Path(scratch))
        appends.append(a)
        reads.append(r)
    return {
        "benchmark": "brain_archive_io",
        "load_average_before": [round(v, 2) for v in load],
        "twenty_appends": summary(appends),
        "read_behind_twenty_queued_writes": summary(reads),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=20)
    result = asyncio.run(run(parser.parse_args().rounds))
    print(json.dumps(result, indent=1))
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / "brain_archive_io.json").write_text(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
