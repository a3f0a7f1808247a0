"""Brain event-ingress benchmark: signed events/s accepted by one uvicorn worker + p99, and
reaction dispatch latency (event POST → prepared reaction's tool call dispatched).

Run: ``uv run python benchmarks/brain_ingress.py`` (bounded: ~3000 events, < 1 min).
Writes benchmarks/results/brain_ingress.json.
"""

from __future__ import annotations

import asyncio
import json
import logging
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import httpx
import structlog

from robot_mcp_kit.models import TaskEvent
from robot_mcp_kit.signing import signed_headers
from robot_stack_testing import free_tcp_port, wait_for_tcp_port

SECRET = (
    "nav-event-secret-for-tests-0123456789abcdef"  # = robot_stack_testing.brain.harness.NAV_SECRET
)
RESULTS = Path(__file__).with_name("results")


def build_container(trace_dir: str) -> Any:
    from robot_stack_testing.brain.harness import make_harness
    from robot_voice_chat.api.container import Adapters
    from robot_voice_chat.composition import assemble
    from robot_voice_chat.services.emitter.base import FakeEventEmitter
    from robot_voice_chat.services.llm.fake import FakeLLM
    from robot_voice_chat.services.speech.fake import FakeSpeechInput, FakeSpeechOutput
    from robot_voice_chat.settings import AppConfig

    h = make_harness(Path(trace_dir), FakeLLM([]))
    config = AppConfig.model_validate(
        {
            "llm": {"_target_": "fake"},
            "speech_output": {"_target_": "fake"},
            "speech_input": {"_target_": "fake"},
            "agent": {"trace_dir": trace_dir, "data_dir": trace_dir, "memory_server": ""},
            "api": {"event_rate_limit": "10000000/minute", "dedupe_size": 4096},
        }
    )
    adapters = Adapters(FakeLLM([]), FakeLLM([]), h.tools, FakeSpeechOutput(), FakeSpeechInput())
    return assemble(config, adapters, FakeEventEmitter())


def serve(port: int) -> None:  # the benchmarked worker (subprocess)
    import logging

    import structlog
    import uvicorn

    from robot_voice_chat.api.app import create_app

    structlog.configure(wrapper_class=structlog.make_filtering_bound_logger(logging.WARNING))
    app = create_app(build_container(tempfile.mkdtemp()), manage_lifecycle=False)
    uvicorn.run(app, host="127.0.0.1", port=port, log_level="error", access_log=False)


def event_body(i: int) -> bytes:
    event = TaskEvent(
        task_id=f"t-{i}",
        server="navigation",
        tool="navigate_to",
        type="progress",
        seq=0,
        ts=time.time(),
        payload={"pct": 10.0},
    )
    return event.model_dump_json().encode()


async def load(port: int, total: int, concurrency: int) -> dict[str, Any]:
    latencies: list[float] = []
    statuses: dict[int, int] = {}
    queue: asyncio.Queue[int] = asyncio.Queue()
    for i in range(total):
        queue.put_nowait(i)
    async with httpx.AsyncClient(base_url=f"http://127.0.0.1:{port}", timeout=10) as client:

        async def worker() -> None:
            while not queue.empty():
                i = queue.get_nowait()
                raw = event_body(i)
                started = time.perf_counter()
                r = await client.post(
                    "/api/agent/events",
                    content=raw,
                    headers=signed_headers("navigation", SECRET, raw),
                )
                latencies.append((time.perf_counter() - started) * 1000)
                statuses[r.status_code] = statuses.get(r.status_code, 0) + 1

        for _ in range(50):  # warm-up
            raw = event_body(10**6)
            await client.post(
                "/api/agent/events", content=raw, headers=signed_headers("navigation", SECRET, raw)
            )
        t0 = time.perf_counter()
        await asyncio.gather(*(worker() for _ in range(concurrency)))
        elapsed = time.perf_counter() - t0
    latencies.sort()
    return {
        "events": total,
        "concurrency": concurrency,
        "statuses": statuses,
        "events_per_s": round(total / elapsed, 1),
        "latency_ms_p50": round(statistics.median(latencies), 2),
        "latency_ms_p99": round(latencies[int(len(latencies) * 0.99) - 1], 2),
    }


async def reaction_latency(samples: int = 200) -> dict[str, Any]:
    """In-process (ASGI): POST of a trigger event → the reaction's tool handler runs."""
    from robot_voice_chat.agent.reactions import Reaction
    from robot_voice_chat.agent.task_registry import TaskHandle
    from robot_voice_chat.api.app import create_app
    from robot_voice_chat.services.llm.fake import reply

    container = build_container(tempfile.mkdtemp())
    container.executor.planner._responses = [reply("", ("wait_for_events", {"reason": "bench"}))]
    fired: list[float] = []
    container.adapters.tools.add(
        "perception.prewarm", lambda a: fired.append(time.perf_counter()) or "ok"
    )
    app = create_app(container, manage_lifecycle=False)
    await container.executor.start("bench")
    run = container.executor.run
    while not run.suspended:  # noqa: ASYNC110 - benchmark polling
        await asyncio.sleep(0.01)
    results = []
    async with httpx.AsyncClient(
        transport=httpx.ASGITransport(app), base_url="http://127.0.0.1"
    ) as client:
        for i in range(samples):
            task_id = f"nav-{i}"
            container.executor.registry.register(
                TaskHandle(task_id, "navigation", "navigate_to", None, run.mission.id)
            )
            run.reactions.add(
                Reaction.model_validate(
                    {
                        "event": {
                            "server": "navigation",
                            "type": "trigger_fired",
                            "task_id": task_id,
                        },
                        "call": {"tool": "perception.prewarm", "arguments": {}},
                    }
                )
            )
            body = (
                TaskEvent(
                    task_id=task_id,
                    server="navigation",
                    tool="navigate_to",
                    type="trigger_fired",
                    seq=0,
                    ts=time.time(),
                    payload={"trigger": {"type": "eta_below", "seconds": 10}},
                )
                .model_dump_json()
                .encode()
            )
            before = len(fired)
            t0 = time.perf_counter()
            await client.post(
                "/api/agent/events",
                content=body,
                headers=signed_headers("navigation", SECRET, body),
            )
            while len(fired) == before:  # noqa: ASYNC110 - measure, don't add latency
                await asyncio.sleep(0)
            results.append((fired[-1] - t0) * 1000)
            run.inbox.clear()
    await container.executor.shutdown()
    results.sort()
    return {
        "samples": samples,
        "post_to_reaction_dispatch_ms_p50": round(statistics.median(results), 3),
        "post_to_reaction_dispatch_ms_p99": round(results[int(samples * 0.99) - 1], 3),
    }


def main() -> None:
    if len(sys.argv) > 2 and sys.argv[1] == "--serve":
        serve(int(sys.argv[2]))
        return
    port = free_tcp_port()
    proc = subprocess.Popen([sys.executable, __file__, "--serve", str(port)])
    try:
        wait_for_tcp_port(port, 30)
        ingress = asyncio.run(load(port, total=3000, concurrency=16))
    finally:
        proc.terminate()
        proc.wait(10)
    structlog.configure(wrapper_class=structlog.make_filtering_bound_logger(logging.WARNING))
    reaction = asyncio.run(reaction_latency())
    result = {"ingress_one_worker": ingress, "reaction_dispatch": reaction}
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / "brain_ingress.json").write_text(json.dumps(result, indent=2))
    print(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
