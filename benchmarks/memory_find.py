"""Benchmark of the memory server's find_processes: latency with 10,000 stored processes and
recall@1/@3 on two paraphrase sets (benchmarks/_memory_paraphrases.py: 35 targets, 37 queries;
benchmarks/_memory_paraphrases_v2.py: 70 more queries for the same targets, other wording).

    uv run python benchmarks/memory_find.py            # writes benchmarks/results/memory_find.json
    python benchmarks/memory_find.py --embeddings --no-mcp --output ...   # needs the extra

The store holds 10,000 generated distractors (deterministic, seed 2002) plus the targets.
Distractors reuse the targets' vocabulary (verbs, objects, places) but never the (object, place)
pair a target reserves, so each query has one right answer. Recall is measured with synonyms
off (plain FTS5 BM25 + porter stemming) and on (default), and with the MiniLM re-ranker when
--embeddings is given. Latency is measured in-process (ranking only) and end to end through a
real ``robot-mcp-memory`` process over streamable HTTP on 127.0.0.1.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import platform
import random
import shutil
import signal
import socket
import sqlite3
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _memory_paraphrases import TARGETS
from _memory_paraphrases_v2 import QUERIES as QUERIES_V2

from robot_mcp_memory.documents import parse_process, render_process
from robot_mcp_memory.service import ProcessMemory
from robot_mcp_memory.store.sqlite_fts import SqliteFtsProcessStore
from robot_stack_testing import fresh_token, mcp_transport

TOKEN = fresh_token()  # the servers' MCP_AUTH_TOKEN
ROOT = Path(__file__).resolve().parent.parent
SEED = 2002
ROBOT_ID = "bench-robot"

VERBS = (
    ("Fetch", "fetch {o} from the {p}"),
    ("Bring", "bring {o} from the {p} to the operator"),
    ("Deliver", "deliver {o} to the {p}"),
    ("Take", "take {o} to the {p}"),
    ("Check", "check the {o} in the {p} and report"),
    ("Inspect", "inspect the {o} in the {p}"),
    ("Clean", "clean the {o} in the {p}"),
    ("Find", "find the {o} somewhere in the {p}"),
    ("Move", "move the {o} out of the {p}"),
    ("Count", "count the {o} in the {p}"),
    ("Photograph", "take a photo of the {o} in the {p}"),
    ("Restock", "restock the {o} in the {p}"),
    ("Sort", "sort the {o} in the {p}"),
    ("Guard", "watch over the {o} in the {p}"),
    ("Return", "return the {o} to the {p}"),
)
OBJECTS = (
    "package",
    "parcel",
    "documents",
    "plant",
    "coffee",
    "keys",
    "trash bags",
    "chairs",
    "laptop",
    "paper",
    "boxes",
    "water bottles",
    "medicine",
    "books",
    "toolbox",
    "flowers",
    "umbrella",
    "monitor",
    "badge",
    "lunch",
    "cables",
    "mail",
    "letters",
    "printouts",
    "supplies",
    "food",
    "projector",
    "pallet",
    "fire extinguisher",
    "first aid kit",
    "windows",
    "lights",
    "thermostat",
    "whiteboard",
    "door",
    "tablet",
    "headset",
    "chargers",
)
PLACES = (
    "mailroom",
    "kitchen",
    "reception",
    "lobby",
    "office",
    "finance office",
    "meeting room",
    "storage closet",
    "lab",
    "server room",
    "loading dock",
    "library",
    "garage",
    "cafeteria",
    "roof terrace",
    "second floor corridor",
    "patient room",
    "printer room",
    "desk",
    "it help desk",
    "gym",
    "archive",
    "workshop",
    "parking lot",
    "break room",
    "hallway",
    "elevator lobby",
    "basement",
    "conference room",
    "warehouse",
    "clinic",
    "studio",
)
MODIFIERS = (
    "",
    "",
    "",
    " urgently",
    " in the morning",
    " after hours",
    " for the manager",
    " carefully",
    " before noon",
    " on Fridays",
    " when asked by the operator",
    " twice a day",
)
STEP_TEMPLATES = (
    "navigate_to({p})",
    "navigate_to({p}) with trigger eta_below 10",
    "prewarm perception find_object({o}) before arrival",
    "find_object({o}) and confirm it with describe_scene",
    "ask_user which {o} is meant if there are several",
    "say that the {o} task has started",
    "wait_for_events until the {o} is in view",
    "pick up the {o} with both arms",
    "put the {o} down gently",
    "report the result to the operator",
    "return to the charging dock",
    "take the elevator to the {p}",
    "log the state of the {o}",
)
PITFALLS = (
    "The door of the {p} was closed (DOOR_CLOSED): asked reception to open it.",
    "The elevator was out of service: took the long corridor instead.",
    "The {o} was not where expected: asked the operator for its last location.",
    "Perception found two {o}: asked the user which one.",
    "Battery went low on the way: docked and resumed later.",
    "The {p} was crowded: waited for people to pass.",
    "Navigation failed once on the ramp: retried at lower speed.",
)
NOTES = (
    "The operator prefers a short spoken confirmation.",
    "Do not enter the {p} during meetings.",
    "Ask before touching the {o}.",
    "Weekends: the {p} is locked.",
)
QUERY_TEMPLATES = (
    "please {v} the {o} in the {p}",
    "{o} {p}",
    "can you {v} the {o}",
    "I need the {o} from the {p}",
    "go to the {p} and {v} the {o}",
)


def slug(text: str) -> str:
    return "-".join("".join(ch if ch.isalnum() else " " for ch in text.lower()).split())


def reserved_pairs() -> set[tuple[str, str]]:
    return {pair for target in TARGETS for pair in target.taken}


def distractors(count: int, rng: random.Random) -> list[str]:
    taken = reserved_pairs()
    documents: list[str] = []
    while len(documents) < count:
        verb, pattern = rng.choice(VERBS)
        obj, place = rng.choice(OBJECTS), rng.choice(PLACES)
        if (obj, place) in taken:
            continue
        modifier = rng.choice(MODIFIERS)
        title = f"{verb} the {obj} {rng.choice(('in', 'at', 'from', 'to'))} the {place}{modifier}"
        steps = [
            template.format(o=obj, p=place)
            for template in rng.sample(STEP_TEMPLATES, rng.randint(3, 6))
        ]
        pitfalls = [
            template.format(o=obj, p=place) for template in rng.sample(PITFALLS, rng.randint(0, 2))
        ]
        notes = [
            template.format(o=obj, p=place) for template in rng.sample(NOTES, rng.randint(0, 1))
        ]
        tags = list(
            dict.fromkeys([obj, place, verb.lower(), rng.choice(("daily", "ops", "fleet"))])
        )
        documents.append(
            render_process(
                f"{slug(title)[:60].strip('-')}-{len(documents)}",
                title,
                pattern.format(o=f"the {obj}", p=place) + modifier,
                tags[: rng.randint(2, 4)],
                steps,
                pitfalls,
                notes,
            )
        )
    return documents


def target_documents() -> list[str]:
    return [
        render_process(t.id, t.title, t.task_pattern, list(t.tags), list(t.steps)) for t in TARGETS
    ]


def build_store(
    path: Path, rng: random.Random, count: int
) -> tuple[SqliteFtsProcessStore, dict[str, Any]]:
    store = SqliteFtsProcessStore(path, ROBOT_ID)
    documents = distractors(count, rng) + target_documents()
    rng.shuffle(documents)
    started = time.perf_counter()
    for markdown in documents:
        store.save(parse_process(markdown))
    elapsed = time.perf_counter() - started
    return store, {
        "processes": len(documents),
        "insert_s": round(elapsed, 2),
        "saves_per_s": round(len(documents) / elapsed, 1),
        "db_mb": round(path.stat().st_size / 1e6, 1),
    }


SET_V1 = [(target.id, query) for target in TARGETS for query in target.queries]
SET_V2 = [(target, query) for target, queries in QUERIES_V2.items() for query in queries]


def recall(
    memory: ProcessMemory, k: int = 3, queries: list[tuple[str, str]] = SET_V1
) -> dict[str, Any]:
    hits_at_k = hits_at_1 = 0
    reciprocal = 0.0
    misses = []
    for expected, query in queries:
        ranked = [item.candidate.process.id for item in memory.find_sync(query, 10)]
        rank = ranked.index(expected) + 1 if expected in ranked else None
        hits_at_k += rank is not None and rank <= k
        hits_at_1 += rank == 1
        reciprocal += 1.0 / rank if rank else 0.0
        if rank is None or rank > k:
            misses.append({"query": query, "expected": expected, "rank": rank, "top3": ranked[:3]})
    return {
        "queries": len(queries),
        f"recall_at_{k}": round(hits_at_k / len(queries), 3),
        "recall_at_1": round(hits_at_1 / len(queries), 3),
        "mrr_at_10": round(reciprocal / len(queries), 3),
        "misses": misses,
    }


def recall_both(memory: ProcessMemory) -> dict[str, Any]:
    """Recall on the first paraphrase set (37 queries) and the second (70 queries)."""
    return {"set_v1": recall(memory), "set_v2": recall(memory, queries=SET_V2)}


def latency_queries(rng: random.Random, count: int) -> list[str]:
    paraphrases = [query for target in TARGETS for query in target.queries]
    generated = [
        rng.choice(QUERY_TEMPLATES).format(
            v=rng.choice(VERBS)[0].lower(), o=rng.choice(OBJECTS), p=rng.choice(PLACES)
        )
        for _ in range(count)
    ]
    return [*(paraphrases * (count // len(paraphrases) // 3 + 1)), *generated][:count]


def summarise_ms(samples: list[float]) -> dict[str, float]:
    ordered = sorted(samples)

    def pct(p: float) -> float:
        return round(ordered[min(len(ordered) - 1, int(p / 100 * len(ordered)))], 3)

    return {
        "calls": len(ordered),
        "p50_ms": pct(50),
        "p95_ms": pct(95),
        "p99_ms": pct(99),
        "max_ms": round(ordered[-1], 3),
        "mean_ms": round(statistics.fmean(ordered), 3),
    }


def in_process_latency(memory: ProcessMemory, queries: list[str]) -> dict[str, float]:
    for query in queries[:20]:
        memory.find_sync(query, 3)
    samples = []
    for query in queries:
        started = time.perf_counter()
        memory.find_sync(query, 3)
        samples.append((time.perf_counter() - started) * 1000)
    return summarise_ms(samples)


def free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


def start_server(db: Path, log_path: Path) -> tuple[subprocess.Popen[bytes], int]:
    """The real server process on a free loopback port, listening (or RuntimeError)."""
    port = free_port()
    env = {
        **os.environ,
        "MCP_TRANSPORT": "streamable-http",
        "MCP_AUTH_TOKEN": TOKEN,
        "MCP_PORT": str(port),
        "MEMORY_DB": str(db),
        "ROBOT_ID": ROBOT_ID,
        "LOG_LEVEL": "WARNING",
        "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST",
        "ROS_DOMAIN_ID": str(random.SystemRandom().randint(60, 99)),
    }
    server = str(Path(sys.executable).parent / "robot-mcp-memory")
    with log_path.open("wb") as log:
        process = subprocess.Popen([server], env=env, stdout=log, stderr=subprocess.STDOUT)
    deadline = time.monotonic() + 30
    while True:
        try:
            socket.create_connection(("127.0.0.1", port), timeout=0.2).close()
            return process, port
        except OSError:
            if time.monotonic() > deadline or process.poll() is not None:
                stop_server(process)
                raise RuntimeError(f"server did not start: {log_path.read_text()}") from None
            time.sleep(0.1)


def stop_server(process: subprocess.Popen[bytes]) -> None:
    process.send_signal(signal.SIGINT)
    try:
        process.wait(timeout=10)
    except subprocess.TimeoutExpired:
        process.kill()
        process.wait(timeout=10)


async def mcp_latency(port: int, queries: list[str]) -> dict[str, Any]:
    from mcp import Client

    samples = []
    async with Client(
        mcp_transport(f"http://127.0.0.1:{port}/mcp", TOKEN), read_timeout_seconds=30
    ) as client:
        for query in queries[:10]:
            await client.call_tool("find_processes", {"query": query, "k": 3})
        for query in queries:
            started = time.perf_counter()
            result = await client.call_tool("find_processes", {"query": query, "k": 3})
            samples.append((time.perf_counter() - started) * 1000)
            if result.is_error:
                raise RuntimeError(f"find_processes failed: {result.content}")
    return {"transport": "streamable-http", **summarise_ms(samples)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--processes", type=int, default=10_000)
    parser.add_argument("--calls", type=int, default=1000)
    parser.add_argument("--mcp-calls", type=int, default=300)
    parser.add_argument("--no-mcp", action="store_true", help="skip the end-to-end MCP part")
    parser.add_argument(
        "--embeddings", action="store_true", help="also measure the MiniLM re-ranker"
    )
    parser.add_argument("--output", type=Path, default=ROOT / "benchmarks/results/memory_find.json")
    args = parser.parse_args()

    rng = random.Random(SEED)
    workdir = Path(tempfile.mkdtemp(prefix="memory-bench-"))
    try:
        db = workdir / "memory.sqlite3"
        store, build = build_store(db, rng, args.processes)
        plain = ProcessMemory(store, synonyms=False)
        default = ProcessMemory(store)
        queries = latency_queries(random.Random(SEED + 1), args.calls)
        result: dict[str, Any] = {
            "benchmark": "memory_find",
            "machine": {
                "python": platform.python_version(),
                "sqlite": sqlite3.sqlite_version,
                "cpus": os.cpu_count(),
            },
            "store": build,
            "recall": {
                "fts_bm25_porter_only": recall_both(plain),
                "default": recall_both(default),
            },
            "latency_in_process": {
                "default": in_process_latency(default, queries),
                "fts_only": in_process_latency(plain, queries),
            },
        }
        if args.embeddings:
            from robot_mcp_memory.embeddings import EmbeddingReranker, MiniLMEmbedder

            embedder = MiniLMEmbedder()
            reranked = ProcessMemory(store, reranker=EmbeddingReranker(embedder))
            result["recall"]["default_plus_minilm_rerank"] = recall_both(reranked)
            result["latency_in_process"]["minilm_rerank"] = in_process_latency(
                reranked, queries[: min(args.calls, 200)]
            )
        store.close()
        if not args.no_mcp:
            process, port = start_server(db, workdir / "server.log")
            try:
                result["latency_mcp_end_to_end"] = asyncio.run(
                    mcp_latency(port, queries[: args.mcp_calls])
                )
            finally:
                stop_server(process)
    finally:
        shutil.rmtree(workdir, ignore_errors=True)

    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_text(json.dumps(result, indent=2) + "\n")
    print(f"stored {build['processes']} processes in {build['insert_s']} s ({build['db_mb']} MB)")
    for name, sets in result["recall"].items():
        for set_name, value in sets.items():
            print(
                f"recall@3 {name} {set_name}: {value['recall_at_3']} "
                f"(recall@1 {value['recall_at_1']}, MRR@10 {value['mrr_at_10']}, "
                f"{value['queries']} queries)"
            )
    for name, value in result["latency_in_process"].items():
        print(f"find in-process {name}: p50 {value['p50_ms']} ms, p99 {value['p99_ms']} ms")
    if "latency_mcp_end_to_end" in result:
        value = result["latency_mcp_end_to_end"]
        print(f"find_processes over MCP: p50 {value['p50_ms']} ms, p99 {value['p99_ms']} ms")
    print(f"wrote {args.output}")


if __name__ == "__main__":
    main()
