"""Cost: 60 s of static frames (with a few scene changes) and a continuous cloud-stage skill.
Cloud calls must stay ≤ 1 + scene changes; compared with the naive count rate × time."""

from __future__ import annotations

import argparse

from _perception_runtime_common import Bench, frames_640x480, write_result

from robot_mcp_perception.models.base import GroundingResult
from robot_mcp_perception.models.fakes import FakeGrounder
from robot_mcp_perception.models.null import NullSegmenter


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--seconds", type=float, default=60.0)
    parser.add_argument("--rate", type=float, default=2.0)
    parser.add_argument("--changes", type=int, default=3)
    args = parser.parse_args()

    grounder = FakeGrounder(GroundingResult(answer="a still scene"), cost_class="cloud")
    bench = Bench(
        grounder, NullSegmenter(), cost={"max_cloud_rate_hz": 1.0, "cloud_requires_gate": True}
    )
    bench.create(
        {
            "name": "scene",
            "mode": "describe",
            "rate_hz": args.rate,
            "outputs": [{"name": "scene_description", "type": "text"}],
        }
    )
    frames = frames_640x480(args.changes + 1)
    segment = args.seconds / (args.changes + 1)
    bench.play(lambda t: frames[min(int(t // segment), args.changes)], 10.0, args.seconds)
    state = bench.node.registry.get("scene")
    skips = dict(state.skips)
    calls = grounder.ground_calls
    bench.close()
    naive = round(args.rate * args.seconds)
    write_result(
        "perception_runtime_cost",
        {
            "seconds": args.seconds,
            "skill_rate_hz": args.rate,
            "scene_changes": args.changes,
            "cloud_calls": calls,
            "limit": 1 + args.changes,
            "naive_calls": naive,
            "saving_ratio": round(1 - calls / naive, 4),
            "skips": skips,
            "published": state.published,
        },
    )


if __name__ == "__main__":
    main()
