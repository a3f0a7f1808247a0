"""Shared harness of the perception runtime benchmarks: an in-process VisionNode on fakes.

Loopback-only ROS discovery and a private domain id are set before rclpy is imported.
"""

from __future__ import annotations

import json
import os
import random
import resource
import statistics
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
os.environ.setdefault("ROS_DOMAIN_ID", str(random.SystemRandom().randint(101, 199)))

import numpy as np
import rclpy
from rclpy.context import Context
from rclpy.executors import MultiThreadedExecutor

from robot_mcp_perception.frames import FrameListener, FrameSource
from robot_mcp_perception.logging_setup import configure_logging
from robot_mcp_perception.models.base import Grounder, Image, Segmenter
from robot_mcp_perception.pipelines import run_skill
from robot_mcp_perception.pipelines.watch import FrameDiffGate
from robot_mcp_perception.runtime import Runtime
from robot_mcp_perception.settings import PerceptionSettings
from robot_mcp_perception.vision_node import VisionNode

RESULTS = Path(__file__).resolve().parent / "results"


class PushSource(FrameSource):
    def __init__(self) -> None:
        super().__init__("bench_camera")

    def start(self, node: Any, on_frame: FrameListener | None = None) -> None:
        self._listener = on_frame

    def stop(self) -> None:
        self._listener = None

    def push(self, image: Image) -> None:
        self._emit(image)


def frames_640x480(count: int, seed: int = 0) -> list[Image]:
    rng = np.random.default_rng(seed)
    out = []
    for index in range(count):
        image = np.full((480, 640, 3), 60 + 40 * index, dtype=np.uint8)
        image[100:300, 200:400] = rng.integers(0, 255, 3, dtype=np.uint8)
        out.append(image)
    return out


class Bench:
    def __init__(
        self, grounder: Grounder, segmenter: Segmenter, runner: Any = None, **settings: Any
    ) -> None:
        configure_logging(True, "ERROR")
        data: dict[str, Any] = {
            "grounder": {"_target_": "bench"},
            "segmenter": {"_target_": "bench"},
            "frame_source": {"_target_": "bench"},
            "artifacts": {"enabled": False},
            "logging": {"level": "ERROR"},
        }
        data.update(settings)
        self.grounder = grounder
        self.source = PushSource()
        self.context = Context()
        rclpy.init(context=self.context)
        runtime = Runtime(
            settings=PerceptionSettings.model_validate(data),
            grounder=grounder,
            segmenter=segmenter,
            frame_source=self.source,
            runner=runner or run_skill,
            gate_factory=FrameDiffGate,
            serve_artifacts=False,
        )
        self.node = VisionNode(runtime, context=self.context)
        self.executor = MultiThreadedExecutor(num_threads=4, context=self.context)
        self.executor.add_node(self.node)
        self.thread = threading.Thread(target=self.executor.spin, daemon=True)
        self.thread.start()

    def create(self, skill: dict[str, Any]) -> None:
        self.node.tasks.create(json.dumps(skill))  # raises SkillError on a bad skill

    def play(
        self,
        frames: Callable[[float], Image],
        fps: float,
        seconds: float,
        every_second: Callable[[float], None] | None = None,
    ) -> None:
        """Push ``frames(t)`` at ``fps`` for ``seconds``; call ``every_second(t)`` each second."""
        start = time.monotonic()
        next_at, next_second = start, start + 1.0
        while (now := time.monotonic()) - start < seconds:
            self.source.push(frames(now - start))
            if every_second is not None and now >= next_second:
                every_second(now - start)
                next_second += 1.0
            next_at += 1.0 / fps
            time.sleep(max(0.0, next_at - time.monotonic()))

    def close(self) -> None:
        self.executor.shutdown(timeout_sec=2.0)
        self.thread.join(timeout=5.0)
        self.node.shutdown()
        self.node.destroy_node()
        rclpy.shutdown(context=self.context)


def cpu_seconds() -> float:
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def rss_mb() -> float:
    pages = int(Path("/proc/self/statm").read_text().split()[1])
    return pages * os.sysconf("SC_PAGE_SIZE") / 1e6


def percentile(values: list[float], q: float) -> float:
    if not values:
        return float("nan")
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, round(q / 100 * (len(ordered) - 1)))]


def write_result(name: str, result: dict[str, Any]) -> Path:
    RESULTS.mkdir(parents=True, exist_ok=True)
    result = {**result, "loadavg_1_5_15": Path("/proc/loadavg").read_text().split()[:3]}
    result.setdefault("cpu_count", os.cpu_count())
    path = RESULTS / f"{name}.json"
    path.write_text(json.dumps(result, indent=2))
    print(json.dumps(result, indent=2))
    print(f"written to {path}")
    return path


__all__ = [
    "Bench",
    "cpu_seconds",
    "frames_640x480",
    "percentile",
    "rss_mb",
    "statistics",
    "write_result",
]
