"""Socket.IO body-limit benchmark (issue 35): a real brain process (login on), a logged-in
engine.io long-polling session, then a 5 MB POST on it: how long until the answer (413), and
how long the brain's stop (SIGTERM, as systemd stops it) then takes — with the session's long
poll (a GET the server holds open, as a browser on the polling transport keeps one) open.
Goal: the POST answered at once, the stop <= 2 s and without a traceback. Before the fix the
POST went unanswered (the client stuck writing) and the stop took 13.5 s.

Run: ``uv run python benchmarks/socketio_body_limit.py [--runs 5]``.
Writes benchmarks/results/socketio_body_limit.json.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import signal
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import httpx

from robot_stack_testing import free_tcp_port, wait_until
from robot_voice_chat.api.auth import hash_password

RESULTS = Path(__file__).with_name("results")
PASSWORD = "socket body limit benchmark"
BIG = 5 * 1024 * 1024


def start_brain(tmp: Path, password_hash: str) -> tuple[str, subprocess.Popen[bytes], Path]:
    port, closed = free_tcp_port(), f"http://127.0.0.1:{free_tcp_port()}/sse"
    env = {k: v for k, v in os.environ.items() if not k.startswith(("RVC_", "ADMIN_"))}
    env.update(
        RVC_DEPLOYMENT="test",
        RVC_CONFIG_OVERRIDES="auth.enabled=true",
        RVC_DATA_DIR=str(tmp / "data"),
        RVC_NAVIGATION_URL=closed,
        RVC_MEMORY_URL=closed,
        RVC_SKILL_CONTROL_URL=closed,
        RVC_PERCEPTION_URL=closed,
        ADMIN_USERNAME="ada",
        ADMIN_PASSWORD_HASH=password_hash,
        ADMIN_SECRET_KEY="a-session-signing-key-that-is-long-enough",
    )
    log = tmp / "brain.log"
    with log.open("wb") as out:
        process = subprocess.Popen(
            [sys.executable, "-m", "robot_voice_chat", "--port", str(port)],
            env=env,
            stdout=out,
            stderr=subprocess.STDOUT,
        )
    url = f"http://127.0.0.1:{port}"

    def serving() -> bool:
        try:
            return httpx.get(f"{url}/api/livez", timeout=2).status_code == 200
        except httpx.HTTPError:
            return False

    wait_until(serving, 60, "the brain serving")
    return url, process, log


def one_run(password_hash: str) -> dict[str, object]:
    with tempfile.TemporaryDirectory() as tmp:
        url, process, log = start_brain(Path(tmp), password_hash)
        try:
            http = httpx.Client(base_url=url, timeout=httpx.Timeout(60.0))
            http.post("/api/auth/login", json={"username": "ada", "password": PASSWORD})
            opened = http.get("/socket.io/", params={"EIO": "4", "transport": "polling"})
            sid = opened.text.split('"sid":"')[1].split('"')[0]
            poll = {"EIO": "4", "transport": "polling", "sid": sid}
            http.post("/socket.io/", params=poll, content=b"40")  # the Socket.IO connect
            http.get("/socket.io/", params=poll)  # its answer
            started = time.perf_counter()
            try:
                status = http.post("/socket.io/", params=poll, content=b"4" + b"x" * BIG)
                answered: object = status.status_code
            except httpx.HTTPError as error:
                answered = type(error).__name__
            post_s = time.perf_counter() - started
            held = threading.Thread(  # the session's long poll, open while the brain stops
                target=lambda: _quietly(http.get, "/socket.io/", params=poll), daemon=True
            )
            held.start()
            time.sleep(0.3)
            stop_started = time.perf_counter()
            process.send_signal(signal.SIGTERM)
            process.wait(60)
            stop_s = time.perf_counter() - stop_started
            return {
                "post_answer": answered,
                "post_s": round(post_s, 3),
                "stop_s": round(stop_s, 3),
                "traceback": "Traceback" in log.read_text(),
            }
        finally:
            if process.poll() is None:
                process.kill()
                process.wait(10)


def _quietly(call: object, *args: object, **kwargs: object) -> None:
    with contextlib.suppress(httpx.HTTPError):
        call(*args, **kwargs)  # type: ignore[operator]


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--runs", type=int, default=5)
    runs = parser.parse_args().runs
    password_hash = hash_password(PASSWORD)
    samples = [one_run(password_hash) for _ in range(runs)]
    posts = [float(s["post_s"]) for s in samples]  # type: ignore[arg-type]
    stops = [float(s["stop_s"]) for s in samples]  # type: ignore[arg-type]
    summary = {
        "runs": runs,
        "answers": sorted({str(s["post_answer"]) for s in samples}),
        "post_s_p50": round(statistics.median(posts), 3),
        "post_s_max": round(max(posts), 3),
        "stop_s_p50": round(statistics.median(stops), 3),
        "stop_s_max": round(max(stops), 3),
        "tracebacks": sum(bool(s["traceback"]) for s in samples),
        "samples": samples,
    }
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / "socketio_body_limit.json").write_text(json.dumps(summary, indent=2))
    print(json.dumps({k: v for k, v in summary.items() if k != "samples"}))


if __name__ == "__main__":
    main()
