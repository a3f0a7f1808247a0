"""Cost: cloud requests versus the budget (spec 000 §8, issue 13 item 2).

1. ``describe``: 60 s of static frames with a few scene changes and a continuous describe
   skill on a fake grounder; cloud calls must stay ≤ 1 + scene changes (naive: rate × time).
2. ``segment_all``: the real GeminiERGrounder (google-genai SDK) against the local strict fake
   Gemini server, a continuous segment_all skill (2×2 tiles + its outputs = 5 requests a run)
   at 2 Hz, the scene changing every few seconds, a flaky service (every 4th request 503, so
   retries happen) and ``max_cloud_calls_per_min`` = 6. Every request the server sees is
   counted; the most in any 60 s window must not exceed the budget.
"""

from __future__ import annotations

import argparse
import json
from typing import Any

from _perception_runtime_common import Bench, frames_640x480, write_result

from robot_mcp_perception.models.base import GroundingResult
from robot_mcp_perception.models.fakes import FakeGrounder
from robot_mcp_perception.models.gemini_er import GeminiERGrounder
from robot_mcp_perception.models.null import NullSegmenter
from robot_stack_testing.perception.fake_gemini import FakeGemini, serve_fake_gemini

POINTS = json.dumps(
    {
        "targets": [
            {"label": "box", "point": [500, 500], "box_2d": [400, 400, 600, 600]},
            {"label": "mug", "point": [200, 300], "box_2d": [150, 250, 250, 350]},
        ],
        "results": [{"name": "count", "value": 2}],
    }
)


def describe_scenario(seconds: float, rate: float, changes: int) -> dict[str, Any]:
    grounder = FakeGrounder(GroundingResult(answer="a still scene"), cost_class="cloud")
    bench = Bench(
        grounder, NullSegmenter(), cost={"max_cloud_rate_hz": 1.0, "cloud_requires_gate": True}
    )
    bench.create(
        {
            "name": "scene",
            "mode": "describe",
            "rate_hz": rate,
            "outputs": [{"name": "scene_description", "type": "text"}],
        }
    )
    frames = frames_640x480(changes + 1)
    segment = seconds / (changes + 1)
    bench.play(lambda t: frames[min(int(t // segment), changes)], 10.0, seconds)
    state = bench.node.registry.get("scene")
    skips, calls, published = dict(state.skips), grounder.ground_calls, state.published
    bench.close()
    naive = round(rate * seconds)
    return {
        "cloud_calls": calls,
        "limit": 1 + changes,
        "naive_calls": naive,
        "saving_ratio": round(1 - calls / naive, 4),
        "skips": skips,
        "published": published,
    }


def segment_all_scenario(
    seconds: float, rate: float, budget: int, change_s: float
) -> dict[str, Any]:
    app = FakeGemini(api_key="bench-key", replies=[(200, POINTS)], fail_every=4)
    with serve_fake_gemini(app) as url:
        grounder = GeminiERGrounder(
            "bench-key", timeout_s=5.0, retries=2, retry_backoff_s=0.05, base_url=url
        )
        grounder.cost_class = "cloud"
        bench = Bench(
            grounder,
            NullSegmenter(),
            cost={
                "max_cloud_calls_per_min": budget,
                "max_cloud_rate_hz": 10.0,
                "cloud_requires_gate": True,
            },
        )
        bench.create(
            {
                "name": "everything",
                "mode": "segment_all",
                "segment": True,
                "rate_hz": rate,
                "outputs": [{"name": "count", "type": "number"}],
            }
        )
        frames = frames_640x480(5)  # consecutive scenes differ; the cycle repeats
        bench.play(lambda t: frames[int(t // change_s) % len(frames)], 10.0, seconds)
        state = bench.node.registry.get("everything")
        skips, runs, published = dict(state.skips), state.runs, state.published
        failures = state.failures
        counted = bench.node.policy.budget.total
        bench.close()
    times = sorted(r["at"] for r in app.requests)
    worst_window = max(
        (sum(1 for t in times if start <= t < start + 60.0) for start in times), default=0
    )
    return {
        "requests_seen_by_server": len(app.requests),
        "requests_refused_by_server": len(app.rejected),
        "max_requests_in_any_60s": worst_window,
        "budget_per_min": budget,
        "within_budget": worst_window <= budget,
        "requests_counted_by_node": counted,
        "requests_per_run": 5,
        "segmentation_runs": runs,  # fresh + on a re-used grounding (scene unchanged)
        "failed_runs": failures,
        "published": published,
        "skips": skips,
        "naive_requests": round(rate * seconds * 5),
    }


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--seconds", type=float, default=60.0)
    parser.add_argument("--rate", type=float, default=2.0)
    parser.add_argument("--changes", type=int, default=3)
    parser.add_argument("--budget", type=int, default=6)
    parser.add_argument("--change-every", type=float, default=5.0)
    args = parser.parse_args()
    write_result(
        "perception_runtime_cost",
        {
            "seconds": args.seconds,
            "skill_rate_hz": args.rate,
            "describe": describe_scenario(args.seconds, args.rate, args.changes),
            "segment_all_fake_gemini": segment_all_scenario(
                args.seconds, args.rate, args.budget, args.change_every
            ),
        },
    )


if __name__ == "__main__":
    main()
