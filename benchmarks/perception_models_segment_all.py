"""segment_all with the offline grounder (AnnotationGrounder) + GrabCut: precision/recall.

A detection is a true positive when its mask has IoU >= 0.5 with a not-yet-matched
ground-truth object (greedy, best IoU first). Goal: precision and recall >= 0.90.
Runs the real router (`run_skill`) on generated 640×480 scenes (tiling, per-tile pointing,
merge/dedupe/NMS, one segmenter call per frame).

    uv run python benchmarks/perception_models_segment_all.py [--scenes 24] [--seed 0]

Prints a summary and writes benchmarks/results/perception_models_segment_all.json.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import logging
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np
import structlog

from robot_mcp_perception.models.annotation import AnnotationGrounder
from robot_mcp_perception.models.grabcut import GrabCutSegmenter
from robot_mcp_perception.pipelines import run_skill
from robot_mcp_perception.pipelines.common import PipelineContext
from robot_mcp_perception.postprocess import mask_iou
from robot_mcp_perception.sample_scenes import generate_scenes, polygon_mask, render_scene
from robot_mcp_perception.skills import Skill

RESULTS = Path(__file__).resolve().parent / "results" / "perception_models_segment_all.json"
IOU = 0.5


async def run(scenes: int, seed: int, directory: Path) -> dict[str, object]:
    generate_scenes(directory, count=scenes, seed=seed)
    ctx = PipelineContext(AnnotationGrounder(str(directory)), GrabCutSegmenter())
    skill = Skill("segment_all", "segment_all", segment=True)
    tp = fp = fn = 0
    ious: list[float] = []
    latencies_ms: list[float] = []
    for index in range(scenes):
        image, doc = render_scene(index, seed)
        t0 = time.perf_counter()
        result = await run_skill(skill, image, ctx)
        latencies_ms.append(1000 * (time.perf_counter() - t0))
        truths = [polygon_mask(a["segmentation"], 640, 480) for a in doc["annotations"]]
        pairs = sorted(
            (
                (mask_iou(d.mask, t), di, ti)
                for di, d in enumerate(result.detections)
                if d.mask is not None
                for ti, t in enumerate(truths)
            ),
            reverse=True,
        )
        used_d: set[int] = set()
        used_t: set[int] = set()
        for iou, di, ti in pairs:
            if iou < IOU or di in used_d or ti in used_t:
                continue
            used_d.add(di)
            used_t.add(ti)
            ious.append(iou)
        tp += len(used_t)
        fp += len(result.detections) - len(used_d)
        fn += len(truths) - len(used_t)
    precision = tp / (tp + fp) if tp + fp else 0.0
    recall = tp / (tp + fn) if tp + fn else 0.0
    return {
        "benchmark": "perception_models_segment_all",
        "grounder": "AnnotationGrounder (offline)",
        "segmenter": "GrabCutSegmenter",
        "image_size": [640, 480],
        "scenes": scenes,
        "seed": seed,
        "iou_threshold": IOU,
        "true_positives": tp,
        "false_positives": fp,
        "false_negatives": fn,
        "precision": round(precision, 4),
        "recall": round(recall, 4),
        "matched_iou_median": round(statistics.median(ious), 4) if ious else None,
        "latency_ms_p50": round(float(np.percentile(latencies_ms, 50)), 1),
        "latency_ms_p99": round(float(np.percentile(latencies_ms, 99)), 1),
        "goals": {"precision": 0.90, "recall": 0.90},
        "passed": precision >= 0.90 and recall >= 0.90,
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", type=int, default=24)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    structlog.configure(wrapper_class=structlog.make_filtering_bound_logger(logging.WARNING))
    with tempfile.TemporaryDirectory() as tmp:
        result = asyncio.run(run(args.scenes, args.seed, Path(tmp)))
    RESULTS.parent.mkdir(parents=True, exist_ok=True)
    RESULTS.write_text(json.dumps(result, indent=2) + "\n")
    print(
        f"segment_all (offline grounder + GrabCut), {result['scenes']} scenes at 640x480: "
        f"precision {result['precision']:.3f}, recall {result['recall']:.3f} at IoU {IOU} "
        f"(TP {result['true_positives']}, FP {result['false_positives']}, "
        f"FN {result['false_negatives']}); "
        f"matched IoU median {result['matched_iou_median']}; "
        f"frame p50 {result['latency_ms_p50']} ms, p99 {result['latency_ms_p99']} ms"
    )
    print(f"{'PASS' if result['passed'] else 'FAIL'} -> {RESULTS}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
