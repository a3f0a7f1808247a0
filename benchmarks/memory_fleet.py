"""Benchmark of the memory stores for a fleet: PostgreSQL versus SQLite with 10,000 processes.

    uv run python benchmarks/memory_fleet.py      # writes benchmarks/results/memory_fleet.json

For each store (SQLite file; PostgreSQL: a throwaway server from Debian's postgresql package,
started as in the tests by robot_stack_testing.postgres, durability settings off as there):
1. 10,000 generated processes + the paraphrase targets of memory_find.py are saved by robot A
   (fleet visibility for PostgreSQL, as deployed; the SQLite file is one robot's);
2. find_processes latency in process (ranking as the server does it: store search, coverage
   stage, outcome ranking), p50/p99 over 1000 queries;
3. recall@1/@3 on both paraphrase sets (the ranking is adapter-independent above the store, so
   the figures say how close the two text searches are);
4. 2 robots × 50 concurrent workers, each doing finds and saves (one save per four operations, a
   new version of a process of its own), on one database: throughput and p50/p99 per operation.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import random
import shutil
import sqlite3
import sys
import tempfile
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))

import memory_find as mf

from robot_mcp_memory.documents import parse_process, render_process
from robot_mcp_memory.service import ProcessMemory
from robot_mcp_memory.store.base import ProcessStore
from robot_mcp_memory.store.postgres import PostgresProcessStore
from robot_mcp_memory.store.sqlite_fts import SqliteFtsProcessStore
from robot_stack_testing.postgres import PostgresServer

ROOT = Path(__file__).resolve().parent.parent
StoreOpener = Callable[[str], ProcessStore]


def fill(store: ProcessStore, count: int) -> dict[str, Any]:
    rng = random.Random(mf.SEED)
    documents = mf.distractors(count, rng) + mf.target_documents()
    rng.shuffle(documents)
    started = time.perf_counter()
    for markdown in documents:
        store.save(parse_process(markdown))
    elapsed = time.perf_counter() - started
    return {
        "processes": len(documents),
        "insert_s": round(elapsed, 1),
        "saves_per_s": round(len(documents) / elapsed, 1),
    }


def concurrent(open_store: StoreOpener, workers: int, operations: int) -> dict[str, Any]:
    """2 robots × ``workers`` threads, ``operations`` each (finds, and every fourth a save)."""
    stores = [open_store("robot-a"), open_store("robot-b")]
    memories = [ProcessMemory(store) for store in stores]
    queries = mf.latency_queries(random.Random(mf.SEED + 2), 500)
    finds: list[float] = []
    saves: list[float] = []
    failures: list[str] = []
    lock = threading.Lock()
    start = threading.Barrier(2 * workers + 1)

    def work(robot: int, worker: int) -> None:
        rng = random.Random(robot * 1000 + worker)
        start.wait(60)
        for index in range(operations):
            began = time.perf_counter()
            try:
                if index % 4 == 3:
                    markdown = render_process(
                        f"fleet-{robot}-{worker}",
                        f"Fleet task {worker}",
                        "deliver the mail to the office",
                        ["fleet"],
                        [f"step {index}"],
                    )
                    stores[robot].save(parse_process(markdown))
                    bucket = saves
                else:
                    memories[robot].find_sync(rng.choice(queries), 3)
                    bucket = finds
            except Exception as exc:  # a benchmark counts failures, it does not stop on one
                with lock:
                    failures.append(repr(exc))
                continue
            elapsed = (time.perf_counter() - began) * 1000
            with lock:
                bucket.append(elapsed)

    threads = [
        threading.Thread(target=work, args=(robot, worker))
        for robot in (0, 1)
        for worker in range(workers)
    ]
    for thread in threads:
        thread.start()
    start.wait(60)
    began = time.perf_counter()
    for thread in threads:
        thread.join()
    wall = time.perf_counter() - began
    for store in stores:
        store.close()
    done = len(finds) + len(saves)
    return {
        "robots": 2,
        "workers_per_robot": workers,
        "operations": done,
        "failures": len(failures),
        "failure_examples": failures[:3],
        "wall_s": round(wall, 2),
        "throughput_ops_per_s": round(done / wall, 1),
        "find": mf.summarise_ms(finds),
        "save": mf.summarise_ms(saves),
        "all": mf.summarise_ms(finds + saves),
    }


def measure(name: str, open_store: StoreOpener, args: argparse.Namespace) -> dict[str, Any]:
    store = open_store("robot-a")
    print(f"{name}: saving {args.processes} processes ...", flush=True)
    build = fill(store, args.processes)
    memory = ProcessMemory(store)
    queries = mf.latency_queries(random.Random(mf.SEED + 1), args.calls)
    result: dict[str, Any] = {
        "store": build,
        "latency_in_process": mf.in_process_latency(memory, queries),
        "recall": mf.recall_both(memory),
    }
    store.close()
    print(f"{name}: 2 robots x {args.workers} concurrent workers ...", flush=True)
    result["concurrent"] = concurrent(open_store, args.workers, args.operations)
    return result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--processes", type=int, default=10_000)
    parser.add_argument("--calls", type=int, default=1000)
    parser.add_argument("--workers", type=int, default=50)
    parser.add_argument("--operations", type=int, default=8, help="per worker")
    parser.add_argument(
        "--output", type=Path, default=ROOT / "benchmarks/results/memory_fleet.json"
    )
    args = parser.parse_args()

    workdir = Path(tempfile.mkdtemp(prefix="memory-fleet-"))
    server = PostgresServer.start()
    try:
        dsn = server.create_database("bench")
        sqlite_path = workdir / "memory.sqlite3"
        result: dict[str, Any] = {
            "benchmark": "memory_fleet",
            "machine": {
                "python": platform.python_version(),
                "sqlite": sqlite3.sqlite_version,
                "postgres_bin": str(server.bin_dir),
                "cpus": os.cpu_count(),
            },
            "sqlite": measure(
                "sqlite",
                lambda robot: SqliteFtsProcessStore(sqlite_path, robot, visibility="fleet"),
                args,
            ),
            "postgres": measure(
                "postgres",
                lambda robot: PostgresProcessStore(dsn, robot, visibility="fleet", pool_size=8),
                args,
            ),
        }
    finally:
        server.stop()
        shutil.rmtree(workdir, ignore_errors=True)

    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_text(json.dumps(result, indent=2) + "\n")
    for name in ("sqlite", "postgres"):
        part = result[name]
        latency, load = part["latency_in_process"], part["concurrent"]
        recall = part["recall"]
        print(
            f"{name}: {part['store']['processes']} processes saved at "
            f"{part['store']['saves_per_s']}/s; find p50 {latency['p50_ms']} ms, "
            f"p99 {latency['p99_ms']} ms; recall@3 {recall['set_v1']['recall_at_3']} / "
            f"{recall['set_v2']['recall_at_3']}; 2x{load['workers_per_robot']} concurrent: "
            f"{load['throughput_ops_per_s']} ops/s, p99 {load['all']['p99_ms']} ms "
            f"(find {load['find']['p99_ms']}, save {load['save']['p99_ms']}), "
            f"{load['failures']} failures"
        )
    print(f"wrote {args.output}")


if __name__ == "__main__":
    main()
