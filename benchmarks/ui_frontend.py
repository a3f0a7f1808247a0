"""Operator UI benchmark (real Chromium, the real brain app in-process with fakes behind it).

Measures: the JS/CSS bundle gzip size; page load → interactive (socket connected and the
message box usable); Socket.IO event → DOM update latency under a burst of mission_plan
snapshots (and that the final snapshot is what the page shows); page memory and DOM size after
a long mission's worth of activity at 2 events/s (time compressed: the events arrive fast).

Run: ``uv run python benchmarks/ui_frontend.py [--rate 200] [--seconds 5] [--minutes 30]``
(needs the UI built by ``make setup``). Writes benchmarks/results/ui_frontend.json.
"""

from __future__ import annotations

import argparse
import asyncio
import gzip
import json
import logging
import statistics
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

import socketio
import structlog
import uvicorn
from playwright.sync_api import Page, sync_playwright

from robot_stack_testing import free_tcp_port, wait_for_tcp_port
from robot_voice_chat.api.app import create_asgi_app
from robot_voice_chat.api.container import Adapters, Container
from robot_voice_chat.composition import assemble
from robot_voice_chat.services.emitter.socketio import SocketIOEventEmitter
from robot_voice_chat.services.llm.fake import FakeLLM
from robot_voice_chat.services.speech.fake import FakeSpeechInput, FakeSpeechOutput
from robot_voice_chat.services.tools.fake import FakeToolBackend
from robot_voice_chat.settings import AppConfig
from robot_voice_chat.socket_events import MissionEventLine, MissionPlan, MissionStarted, StepView

ROOT = Path(__file__).resolve().parents[1]
STATIC = ROOT / "packages" / "robot_voice_chat" / "src" / "robot_voice_chat" / "static"
RESULTS = Path(__file__).with_name("results")
MISSION = "m-bench1"

# In the page: every DOM change of step s2's detail ("seq <n> at <epoch ms>") → latency.
OBSERVER = """() => {
  window.__seen = []; window.__lastSeq = -1;
  new MutationObserver(() => {
    const el = document.querySelector("section[aria-label=Mission] li[data-step-id=s2]");
    const m = el && /seq (\\d+) at (\\d+)/.exec(el.textContent || "");
    if (!m) return;
    const seq = Number(m[1]);
    if (seq !== window.__lastSeq) {
      window.__lastSeq = seq;
      window.__seen.push([seq, Date.now() - Number(m[2])]);
    }
  }).observe(document.body, {subtree: true, childList: true, characterData: true});
}"""


def container(trace_dir: str) -> Container:
    config = AppConfig.model_validate(
        {
            "llm": {"_target_": "fake"},
            "speech_output": {"_target_": "fake"},
            "speech_input": {"_target_": "fake"},
            "agent": {"trace_dir": trace_dir, "memory_server": ""},
        }
    )
    sio = socketio.AsyncServer(async_mode="asgi")
    adapters = Adapters(
        FakeLLM([]), FakeLLM([]), FakeToolBackend(), FakeSpeechOutput(), FakeSpeechInput()
    )
    return assemble(config, adapters, SocketIOEventEmitter(sio), sio)


class Brain:
    """The brain app on uvicorn in a thread; ``emit`` schedules events on its loop."""

    def __init__(self, app: Container, port: int) -> None:
        self.container, self.port = app, port
        config = uvicorn.Config(
            create_asgi_app(app), host="127.0.0.1", port=port, log_level="error"
        )
        self.server = uvicorn.Server(config)
        self.loop = asyncio.new_event_loop()
        self.thread = threading.Thread(target=self._run, daemon=True)

    def _run(self) -> None:
        asyncio.set_event_loop(self.loop)
        self.loop.run_until_complete(self.server.serve())

    def __enter__(self) -> Brain:
        self.thread.start()
        wait_for_tcp_port(self.port, 30.0)
        return self

    def __exit__(self, *exc: Any) -> None:
        self.server.should_exit = True
        self.thread.join(timeout=10)

    def run(self, coro: Any, timeout_s: float = 600) -> Any:
        return asyncio.run_coroutine_threadsafe(coro, self.loop).result(timeout_s)


def snapshot(seq: int, state: str = "running") -> MissionPlan:
    return MissionPlan(
        mission_id=MISSION,
        state=state,  # type: ignore[arg-type]
        started_at=time.time() - 60,
        steps=[
            StepView(id="s1", title="Drive to the mailroom", status="succeeded", detail="arrived"),
            StepView(
                id="s2",
                title="Look for the package",
                status="running",
                detail=f"seq {seq} at {int(time.time() * 1000)}",
            ),
            StepView(id="s3", title="Tell the user", status="pending"),
        ],
    )


async def burst(brain: Brain, rate: float, seconds: float) -> int:
    emitter = brain.container.emitter
    await emitter.emit(
        MissionStarted(mission_id=MISSION, instruction="bench", started_at=time.time())
    )
    count = int(rate * seconds)
    start = time.perf_counter()
    for seq in range(count):
        await emitter.emit(snapshot(seq))
        delay = start + (seq + 1) / rate - time.perf_counter()
        if delay > 0:
            await asyncio.sleep(delay)
    return count


async def long_mission(brain: Brain, events: int, per_second: float) -> None:
    emitter = brain.container.emitter
    start = time.perf_counter()
    for i in range(events):
        await emitter.emit(
            MissionEventLine(
                mission_id=MISSION,
                kind="task_event",
                text=f"nav-7 progress {i}: ETA {events - i} s, {100 * i // events} %",
                ts=time.time(),
            )
        )
        if i % 2 == 0:
            await emitter.emit(snapshot(10_000_000 + i))
        delay = start + (i + 1) / per_second - time.perf_counter()
        if delay > 0:
            await asyncio.sleep(delay)


def page_memory(page: Page) -> dict[str, float]:
    page.evaluate("() => window.gc && window.gc()")
    return page.evaluate(
        """() => ({
          heap_mb: performance.memory.usedJSHeapSize / 1048576,
          dom_nodes: document.getElementsByTagName('*').length,
          activity_lines: document.querySelectorAll('section[aria-label=Activity] li').length,
        })"""
    )


def bundle_sizes() -> dict[str, float]:
    sizes = {"js_gzip_kb": 0.0, "css_gzip_kb": 0.0}
    for path in (STATIC / "assets").iterdir():
        key = (
            "js_gzip_kb"
            if path.suffix == ".js"
            else "css_gzip_kb"
            if path.suffix == ".css"
            else None
        )
        if key:
            sizes[key] += len(gzip.compress(path.read_bytes(), 9)) / 1024
    return {k: round(v, 1) for k, v in sizes.items()}


def percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(q * len(ordered)))]


def main() -> None:
    logging.disable(logging.INFO)  # the brain's per-request log lines would drown the summary
    structlog.configure(wrapper_class=structlog.make_filtering_bound_logger(logging.WARNING))
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rate", type=float, default=200.0, help="mission_plan snapshots/s")
    parser.add_argument("--seconds", type=float, default=5.0, help="burst length")
    parser.add_argument("--minutes", type=float, default=30.0, help="long mission (2 events/s)")
    parser.add_argument("--speedup", type=float, default=100.0, help="time compression")
    args = parser.parse_args()
    if not (STATIC / "index.html").is_file():
        raise SystemExit("the UI is not built: run make setup")
    result: dict[str, Any] = {"bundle": bundle_sizes()}
    with tempfile.TemporaryDirectory() as tmp, Brain(container(tmp), free_tcp_port()) as brain:
        url = f"http://127.0.0.1:{brain.port}/"
        with sync_playwright() as playwright:
            browser = playwright.chromium.launch(
                executable_path="/usr/bin/chromium",
                args=["--no-sandbox", "--enable-precise-memory-info", "--js-flags=--expose-gc"],
            )
            loads = []
            for _ in range(5):
                page = browser.new_page(viewport={"width": 1280, "height": 800})
                started = time.perf_counter()
                page.goto(url)
                page.wait_for_selector("[data-socket-state=connected]")
                page.get_by_role("textbox", name="Message").wait_for()
                loads.append((time.perf_counter() - started) * 1000)
                page.close()
            result["load_to_interactive_ms"] = {
                "p50": round(statistics.median(loads), 1),
                "max": round(max(loads), 1),
                "runs": len(loads),
            }

            page = browser.new_page(viewport={"width": 1280, "height": 800})
            page.goto(url)
            page.wait_for_selector("[data-socket-state=connected]")
            page.evaluate(OBSERVER)
            sent = brain.run(burst(brain, args.rate, args.seconds))
            page.wait_for_function(f"() => window.__lastSeq === {sent - 1}", timeout=30_000)
            seen: list[list[float]] = page.evaluate("() => window.__seen")
            latencies = [lat for _, lat in seen]
            result["event_to_dom"] = {
                "rate_per_s": args.rate,
                "sent": sent,
                "rendered_distinct": len(seen),
                "final_state_shown": seen[-1][0] == sent - 1,
                "p50_ms": percentile(latencies, 0.5),
                "p99_ms": percentile(latencies, 0.99),
                "max_ms": max(latencies),
            }

            before = page_memory(page)
            events = int(args.minutes * 60 * 2)
            brain.run(long_mission(brain, events, 2 * args.speedup))
            page.wait_for_timeout(1000)
            after = page_memory(page)
            result["long_mission"] = {
                "events": events,
                "simulated_minutes": args.minutes,
                "before": {k: round(v, 2) for k, v in before.items()},
                "after": {k: round(v, 2) for k, v in after.items()},
            }
            browser.close()
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / "ui_frontend.json").write_text(json.dumps(result, indent=2))
    print(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
