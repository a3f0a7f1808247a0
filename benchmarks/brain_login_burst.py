"""Login-burst benchmark: the brain's peak memory and answers when 60 logins arrive at once
(from one address, then from 60 addresses via a trusted proxy's X-Forwarded-For), with the
robot preset's login settings. Each argon2 check needs ~64 MiB; the cap on concurrent checks
(auth.login_concurrency) is what bounds the peak.

Run: ``uv run python benchmarks/brain_login_burst.py`` (< 1 min).
Writes benchmarks/results/brain_login_burst.json.
"""

from __future__ import annotations

import asyncio
import json
import os
import subprocess
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

import httpx

from robot_stack_testing import free_tcp_port, wait_for_tcp_port
from robot_voice_chat.api.auth import hash_password

RESULTS = Path(__file__).with_name("results")
BURST = 60


def peak_rss_mib(pid: int) -> float:
    """VmHWM: the process's peak resident set size so far."""
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) / 1024
    raise RuntimeError("no VmHWM in /proc/<pid>/status")


async def burst(url: str, forwarded: bool) -> dict[str, int]:
    limits = httpx.Limits(max_connections=BURST)
    async with httpx.AsyncClient(base_url=url, limits=limits, timeout=120) as http:

        async def attempt(i: int) -> int:
            headers = {"X-Forwarded-For": f"10.0.{i // 250}.{i % 250 + 1}"} if forwarded else {}
            body = {"username": "operator", "password": f"guess-{i}"}
            return (await http.post("/api/auth/login", json=body, headers=headers)).status_code

        statuses = await asyncio.gather(*(attempt(i) for i in range(BURST)))
    return {str(k): v for k, v in sorted(Counter(statuses).items())}


def main() -> None:
    port = free_tcp_port()
    with tempfile.TemporaryDirectory() as tmp:
        closed = f"http://127.0.0.1:{free_tcp_port()}/sse"
        env = {k: v for k, v in os.environ.items() if not k.startswith(("RVC_", "ADMIN_"))}
        env.update(
            RVC_DEPLOYMENT="test",
            RVC_CONFIG_OVERRIDES="auth.enabled=true",
            RVC_DATA_DIR=tmp,
            ADMIN_PASSWORD_HASH=hash_password("the right password"),
            ADMIN_SECRET_KEY="a-session-signing-key-that-is-long-enough",
            **{
                f"RVC_{s}_URL": closed
                for s in ("NAVIGATION", "MEMORY", "SKILL_CONTROL", "PERCEPTION")
            },
        )
        brain = subprocess.Popen(
            [sys.executable, "-m", "robot_voice_chat", "--port", str(port)],
            env=env,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        try:
            wait_for_tcp_port(port, 60.0)
            url = f"http://127.0.0.1:{port}"
            idle = peak_rss_mib(brain.pid)
            started = time.monotonic()
            one_address = asyncio.run(burst(url, forwarded=False))
            many_addresses = asyncio.run(burst(url, forwarded=True))
            seconds = time.monotonic() - started
            peak = peak_rss_mib(brain.pid)
        finally:
            brain.kill()
            brain.wait(10)
    result = {
        "burst": BURST,
        "statuses_one_address": one_address,
        "statuses_sixty_addresses": many_addresses,
        "peak_rss_mib": round(peak, 1),
        "idle_peak_rss_mib": round(idle, 1),
        "seconds": round(seconds, 2),
    }
    print(
        f"login burst x{BURST}: one address {one_address}, 60 addresses {many_addresses}; "
        f"peak RSS {peak:.0f} MiB (idle {idle:.0f} MiB), {seconds:.1f} s"
    )
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / "brain_login_burst.json").write_text(json.dumps(result, indent=2) + "\n")


if __name__ == "__main__":
    main()
