"""Overload: a grounder taking 800 ms, frames at 30 Hz. In-flight never above max_in_flight,
result age p99 < 2 × model latency, RSS flat (60 s by default; --seconds 300 for 5 min)."""

from __future__ import annotations

import argparse
import threading
import time

from _perception_runtime_common import Bench, frames_640x480, percentile, rss_mb, write_result

from robot_mcp_perception.models.base import GroundedTarget, GroundingResult
from robot_mcp_perception.models.fakes import FakeGrounder
from robot_mcp_perception.models.null import NullSegmenter

MODEL_S = 0.8


class CountingGrounder(FakeGrounder):
    """FakeGrounder that keeps no call history (the benchmark watches memory)."""

    async def ground(self, *args, **kwargs):  # type: ignore[no-untyped-def]
        result = await super().ground(*args, **kwargs)
        self.calls.clear()
        return result


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--seconds", type=float, default=60.0)
    parser.add_argument("--skills", type=int, default=4)
    args = parser.parse_args()

    target = GroundedTarget("box", (200, 100, 400, 300), [(300, 200)], confidence=0.9)
    grounder = CountingGrounder(
        GroundingResult(answer="a box", targets=[target]), delay_s=MODEL_S, cost_class="local"
    )
    max_in_flight = 4
    bench = Bench(
        grounder,
        NullSegmenter(),
        node={"max_in_flight": max_in_flight, "workers": 2, "processing_frequency": 5.0},
    )
    for index in range(args.skills):
        bench.create(
            {"name": f"s{index}", "mode": "ground_and_segment", "grounding": "box", "rate_hz": 5.0}
        )
    frames = frames_640x480(2)
    in_flight_max = 0
    stop = threading.Event()

    def sample_in_flight() -> None:
        nonlocal in_flight_max
        while not stop.is_set():
            in_flight_max = max(in_flight_max, bench.node.scheduler.in_flight)
            time.sleep(0.005)

    sampler = threading.Thread(target=sample_in_flight, daemon=True)
    sampler.start()
    ages: list[float] = []
    rss: list[tuple[float, float]] = []

    def every_second(t: float) -> None:
        ages.extend(bench.node.latencies_ms)
        bench.node.latencies_ms.clear()
        rss.append((round(t, 1), round(rss_mb(), 2)))

    bench.play(lambda t: frames[int(t * 30) % 2], 30.0, args.seconds, every_second)
    stop.set()
    sampler.join()
    stats = bench.node.scheduler.stats.as_dict()
    bench.close()
    warm = [mb for t, mb in rss if t >= 10.0] or [mb for _, mb in rss]
    write_result(
        "perception_runtime_overload",
        {
            "seconds": args.seconds,
            "variant": "5 min" if args.seconds >= 300 else f"{args.seconds:g} s",
            "model_latency_s": MODEL_S,
            "frame_hz": 30,
            "skills": args.skills,
            "max_in_flight": max_in_flight,
            "in_flight_max_observed": in_flight_max,
            "scheduler_peak_in_flight": stats["peak_in_flight"],
            "results": len(ages),
            "result_age_ms_p50": round(percentile(ages, 50), 1),
            "result_age_ms_p99": round(percentile(ages, 99), 1),
            "result_age_limit_ms": 2 * MODEL_S * 1000,
            "rss_mb_after_10s_first_last": [warm[0], warm[-1]],
            "rss_mb_growth_after_10s": round(warm[-1] - warm[0], 2),
            "rss_mb_series": rss,
            "scheduler": stats,
        },
    )


if __name__ == "__main__":
    main()
