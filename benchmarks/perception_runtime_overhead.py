"""Overhead: 10 skills × 5 Hz on 640×480 frames at 30 Hz, zero-latency fake grounder +
NullSegmenter. Achieved rate vs requested, added latency (source stamp → publish), CPU %."""

from __future__ import annotations

import argparse
import time

from _perception_runtime_common import Bench, cpu_seconds, frames_640x480, percentile, write_result

from robot_mcp_perception.models.base import GroundedTarget, GroundingResult, Image
from robot_mcp_perception.models.fakes import FakeGrounder
from robot_mcp_perception.models.null import NullSegmenter
from robot_mcp_perception.pipelines.common import Detection, PipelineContext, SkillResult
from robot_mcp_perception.skills import Skill


async def passthrough_runner(
    skill: Skill, image: Image, ctx: PipelineContext, reuse: GroundingResult | None = None
) -> SkillResult:
    """Grounder + segmenter called directly, no pipeline post-processing: isolates the
    runtime's own overhead (scheduling, conversion, publishing)."""
    grounding = reuse or await ctx.grounder.ground(image, skill.grounding, [], skill.mode)
    detections = [
        Detection(
            t.label,
            t.confidence or 1.0,
            t.kind,
            t.box,
            ctx.segmenter.segment_box(image, t.box),
            t.points[0],
        )
        for t in grounding.targets
        if t.box is not None
    ]
    return SkillResult(detections, {}, grounding)


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--runner", choices=["passthrough", "pipelines"], default="passthrough")
    parser.add_argument("--seconds", type=float, default=30.0)
    parser.add_argument("--skills", type=int, default=10)
    parser.add_argument("--rate", type=float, default=5.0)
    args = parser.parse_args()

    target = GroundedTarget("box", (200, 100, 400, 300), [(300, 200)], confidence=0.9)
    grounder = FakeGrounder(GroundingResult(answer="a box", targets=[target]), cost_class="local")
    bench = Bench(
        grounder,
        NullSegmenter(),
        node={"max_in_flight": 16, "workers": 4, "processing_frequency": args.rate},
        runner=passthrough_runner if args.runner == "passthrough" else None,
    )
    for index in range(args.skills):
        bench.create(
            {
                "name": f"s{index}",
                "mode": "ground_and_segment",
                "grounding": "the box",
                "rate_hz": args.rate,
            }
        )
    frames = frames_640x480(2)
    bench.play(lambda t: frames[0], 30.0, 2.0)  # warm-up
    before = {s.skill.name: s.published for s in bench.node.registry.states()}
    bench.node.latencies_ms.clear()
    latencies: list[float] = []
    cpu0, wall0 = cpu_seconds(), time.monotonic()

    def collect(_: float) -> None:
        latencies.extend(bench.node.latencies_ms)
        bench.node.latencies_ms.clear()

    bench.play(lambda t: frames[int(t * 30) % 2], 30.0, args.seconds, collect)
    collect(0.0)
    cpu, wall = cpu_seconds() - cpu0, time.monotonic() - wall0
    published = sum(s.published - before[s.skill.name] for s in bench.node.registry.states())
    stats = bench.node.scheduler.stats.as_dict()
    bench.close()
    requested = args.skills * args.rate * wall
    write_result(
        f"perception_runtime_overhead_{args.runner}",
        {
            "runner": args.runner,
            "seconds": round(wall, 2),
            "skills": args.skills,
            "rate_hz_per_skill": args.rate,
            "frame_hz": 30,
            "frame_size": [640, 480],
            "published": published,
            "requested": round(requested, 1),
            "achieved_ratio": round(published / requested, 4),
            "latency_ms_p50": round(percentile(latencies, 50), 3),
            "latency_ms_p99": round(percentile(latencies, 99), 3),
            "latency_samples": len(latencies),
            "cpu_percent_of_one_core": round(100 * cpu / wall, 1),
            "cpu_note": "whole benchmark process: node + frame producer + fake models",
            "scheduler": stats,
            "targets": {"achieved_ratio": ">= 0.95", "p50_ms": "< 5", "p99_ms": "< 25"},
        },
    )


if __name__ == "__main__":
    main()
