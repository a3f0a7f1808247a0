"""Spoken stop (issue 36): how fast "stop" said on the robot's microphone topic halts a drive,
read from ROS, and what the microphone listener costs while nobody speaks.

On one start of the local stack (robot-sim, memory, navigation, the brain on the dev preset as
shipped with its on-board recognizer, robot-audio-listener), a microphone is played from this
process: room noise (a little white noise, as any microphone has) published continuously on
``/audio_stamped`` in real time (100 ms AudioDataStamped chunks, AudioInfo latched). Then:

- ``listener_cpu``: the listener's CPU (utime + stime from /proc) over ``--idle-s`` of room
  noise with nobody speaking, in % of one core (goal <= 15 %);
- per run: "go to the <place>" over ``POST /api/chat``, the robot seen moving on /amcl_pose,
  then espeak-ng's "stop" (en-us, 180 wpm) mixed into the stream. ``stop_to_halted``: from the
  last chunk of the spoken word to the header stamp of the first /amcl_pose message at the final
  position (once still 0.5 s) (goal p99 <= 1.5 s). A run the robot does not halt in within 15 s
  is counted ``missed``. The stop latches and pauses the mission; both are cleared (the
latch, then "abort") before the next run.

Run: ``uv run python benchmarks/spoken_stop.py [--runs 10] [--idle-s 20]``. Writes
benchmarks/results/spoken_stop.json.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

import httpx
import numpy as np

from robot_sim.say import AUDIO_TOPIC, INFO_TOPIC, RATE, speech
from robot_stack_testing import async_wait_until
from robot_stack_testing.mission_driver import fresh_secret, stack_env
from robot_stack_testing.plugin import pick_ros_domain_id
from robot_stack_testing.pose_watch import AmclWatch
from robot_stack_testing.stack import free_port_overrides, local_stack, stack_defaults

ROOT = Path(__file__).resolve().parents[1]
STACK_FILE = ROOT / "deploy" / "local-stack.yaml"
RESULTS = Path(__file__).with_name("results")
PLACES = ["kitchen", "meeting_room", "mailroom", "dock", "desk_alice", "reception"]
CHUNK = RATE // 10  # 100 ms


def percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, max(0, round(q * (len(ordered) - 1))))]


def summary(values: list[float]) -> dict[str, Any]:
    if not values:
        return {"n": 0}
    ms = [v * 1000 for v in values]
    return {
        "n": len(ms),
        "p50_ms": round(percentile(ms, 0.5), 1),
        "p99_ms": round(percentile(ms, 0.99), 1),
        "max_ms": round(max(ms), 1),
    }


class Microphone:
    """A microphone on /audio_stamped: room noise in real time; ``say`` mixes speech in and
    returns the wall time its last chunk went out."""

    def __init__(self) -> None:
        import rclpy
        from audio_common_msgs.msg import AudioDataStamped, AudioInfo
        from rclpy.context import Context
        from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

        self._message = AudioDataStamped
        self._context = Context()
        rclpy.init(context=self._context)
        self._node = rclpy.create_node("bench_microphone", context=self._context)
        latched = QoSProfile(
            depth=1,
            durability=DurabilityPolicy.TRANSIENT_LOCAL,
            reliability=ReliabilityPolicy.RELIABLE,
        )
        self._info = self._node.create_publisher(AudioInfo, INFO_TOPIC, latched)
        self._info.publish(
            AudioInfo(channels=1, sample_rate=RATE, sample_format="S16LE", bitrate=RATE * 16,
                      coding_format="WAVE")
        )  # fmt: skip
        self._audio = self._node.create_publisher(AudioDataStamped, AUDIO_TOPIC, 50)
        self._rng = np.random.default_rng(0)
        self._speech: list[np.ndarray] = []
        self._said = threading.Event()
        self._said_at = 0.0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def say(self, pcm: np.ndarray, timeout_s: float = 30.0) -> float:
        self._said.clear()
        padded = np.concatenate([pcm, np.zeros((-pcm.size) % CHUNK)]).astype(np.float64)
        self._speech = [padded[i : i + CHUNK] for i in range(0, padded.size, CHUNK)]
        if not self._said.wait(timeout_s):
            raise TimeoutError("the speech was not published")
        return self._said_at

    def _run(self) -> None:
        started = time.monotonic()
        index = 0
        while not self._stop.is_set():
            chunk = self._rng.standard_normal(CHUNK) * 8.0
            if self._speech:
                chunk = chunk + self._speech.pop(0)
                last = not self._speech
            else:
                last = False
            message = self._message()
            message.header.stamp = self._node.get_clock().now().to_msg()
            message.audio.data = np.clip(chunk, -32768, 32767).astype("<i2").tobytes()
            self._audio.publish(message)
            if last:
                self._said_at = time.time()
                self._said.set()
            index += 1
            time.sleep(max(0.0, started + index * 0.1 - time.monotonic()))

    def close(self) -> None:
        import rclpy

        self._stop.set()
        self._thread.join(timeout=5)
        self._node.destroy_node()
        rclpy.try_shutdown(context=self._context)


def cpu_seconds(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


async def one_run(
    http: httpx.AsyncClient, watch: AmclWatch, mic: Microphone, stop: np.ndarray, place: str
) -> dict[str, Any]:
    started = (await http.post("/api/chat", json={"text": f"go to the {place}"})).json()
    if started.get("route") != "mission_started":
        return {"place": place, "error": f"not started: {started}"}
    await async_wait_until(watch.moving, 60, "the robot driving", 0.05)
    said = await asyncio.to_thread(mic.say, stop)
    try:
        await async_wait_until(lambda: (watch.halted_at() or 0) > said - 0.5, 15, "halted", 0.05)
    except TimeoutError:
        row: dict[str, Any] = {"place": place, "missed": True}
    else:
        halted = watch.halted_at()
        assert halted is not None
        row = {"place": place, "stop_to_halted_s": halted - said}
    await settle(http)
    return row


async def settle(http: httpx.AsyncClient) -> None:
    """The stop latched (soon after the halt) and paused the mission: clear the latch, then
    end the mission ("abort"), so that the next run starts from rest."""

    async def latched() -> bool:
        return bool((await http.get("/api/safety")).json()["latched"])

    try:
        await async_wait_until(latched, 10, "the stop latched", 0.1)
    except TimeoutError:  # the stop was not heard: only the mission to end
        pass
    else:
        await http.post("/api/safety/clear", json={"reason": "benchmark: next run"})
    await http.post("/api/chat", json={"text": "abort"})

    async def idle() -> bool:
        return (await http.get("/api/agent/missions")).json()["active"] is None

    await async_wait_until(idle, 30, "no mission", 0.1)


async def bench(runs: int, idle_s: float) -> dict[str, Any]:
    placeholders = {
        **stack_defaults(STACK_FILE),
        **free_port_overrides(STACK_FILE),
        "nav_time_scale": "1",
        "brain_config_overrides": "",
    }
    brain = f"http://127.0.0.1:{placeholders['brain_port']}"
    stop = speech("stop", "en-us", 180)
    watch = AmclWatch()
    mic = Microphone()
    rows: list[dict[str, Any]] = []
    cpu_percent = None
    try:
        with (
            tempfile.TemporaryDirectory() as tmp,
            local_stack(
                ROOT,
                Path(tmp) / "var",
                stack_env(fresh_secret()),
                overrides=placeholders,
                only={"robot_sim", "memory", "navigation", "brain", "audio_listener"},
            ) as services,
        ):
            listener = services["audio_listener"].pid
            await asyncio.sleep(3)  # the listener matched and past its start-up
            before, t0 = cpu_seconds(listener), time.monotonic()
            await asyncio.sleep(idle_s)  # room noise only: what listening costs
            cpu_percent = 100 * (cpu_seconds(listener) - before) / (time.monotonic() - t0)
            print(json.dumps({"listener_cpu_percent": round(cpu_percent, 2)}), flush=True)
            async with httpx.AsyncClient(base_url=brain, timeout=30.0) as http:

                async def navigation_up() -> bool:
                    data = (await http.get("/api/readyz")).json()["data"]
                    return bool(data["mcp_servers"].get("navigation") == "connected")

                await async_wait_until(navigation_up, 90, "navigation connected", 0.2)
                for i in range(runs):
                    await async_wait_until(
                        lambda: watch.halted_at() is not None, 30, "still before a run", 0.05
                    )
                    row = await one_run(http, watch, mic, stop, PLACES[i % len(PLACES)])
                    rows.append(row)
                    print(json.dumps(row), flush=True)
    finally:
        mic.close()
        watch.close()
    good = [r for r in rows if "stop_to_halted_s" in r]
    return {
        "runs": len(rows),
        "missed": sum(bool(r.get("missed")) for r in rows),
        "errors": sum("error" in r for r in rows),
        "stop_to_halted": summary([r["stop_to_halted_s"] for r in good]),
        "listener_cpu_percent_idle": None if cpu_percent is None else round(cpu_percent, 2),
        "idle_s": idle_s,
        "rows": rows,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=10)
    parser.add_argument("--idle-s", type=float, default=20.0)
    args = parser.parse_args()
    # ROS on loopback, on a domain of its own (other stacks may run on this host)
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    os.environ["ROS_DOMAIN_ID"] = str(pick_ros_domain_id())
    result = asyncio.run(bench(args.runs, args.idle_s))
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / "spoken_stop.json").write_text(json.dumps(result, indent=2) + "\n")
    print(json.dumps({k: v for k, v in result.items() if k != "rows"}, indent=2))


if __name__ == "__main__":
    main()
