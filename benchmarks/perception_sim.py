"""Perception measured in robot-sim's office (issue 29): the vision node's masks against the
MuJoCo renderer's segmentation, on views the camera really takes.

N views are rendered from poses around the named places (up to 0.5 m off, turned up to ±0.5
rad, so objects sit anywhere in the frame, partly cut or hidden), saved the way robot-sim
saves them (PNG + annotation JSON in a folder) and run through the vision node's real router
(``run_skill``) with the offline grounder (AnnotationGrounder, reading that folder) + GrabCut:

- **ground_and_segment**: one skill per object in view, grounded on its label; the object's IoU
  is the best IoU of a returned mask with the object's true pixels (0 when none). Recall: the
  share of objects in view with IoU ≥ 0.5.
- **segment_all**: one skill per view; detections matched greedily to objects (IoU ≥ 0.5):
  precision, recall, matched IoU.
Objects in view: at least ``MIN_PIXELS`` visible pixels (the annotation's own rule). Time per
frame: the router's wall time. The grounder answers from the renderer's annotation, so these
figures measure the segmenter (GrabCut) on rendered views and the annotation contract, not a
model's grounding.

    uv run python benchmarks/perception_sim.py [--views 40] [--seed 0]

JSON in benchmarks/results/perception_sim.json.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import logging
import math
import random
import statistics
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
import structlog

from robot_mcp_navigation.motion.base import Pose
from robot_mcp_perception.models.annotation import AnnotationGrounder
from robot_mcp_perception.models.grabcut import GrabCutSegmenter
from robot_mcp_perception.pipelines import run_skill
from robot_mcp_perception.pipelines.common import PipelineContext
from robot_mcp_perception.postprocess import mask_iou
from robot_mcp_perception.skills import Skill
from robot_sim.camera import Camera
from robot_sim.config import default_world_path
from robot_sim.render.annotate import MIN_PIXELS
from robot_sim.render.renderer import MujocoRenderer
from robot_sim.store import SceneStore
from robot_sim.world import load_world

RESULTS = Path(__file__).resolve().parent / "results" / "perception_sim.json"
IOU = 0.5


def q(values: list[float], p: float) -> float | None:
    return round(float(np.percentile(values, p)), 3) if values else None


def views(count: int, seed: int, directory: Path) -> list[tuple[Any, list[tuple[str, Any]]]]:
    """(rgb, [(label, true mask)]) of ``count`` views that show at least one object."""
    world = load_world(default_world_path())
    rng = random.Random(seed)
    renderer = MujocoRenderer(world)
    camera = Camera(world, SceneStore(directory, keep=10 * count), renderer)
    furnished = [p for p in world.places if world.objects_at(p)]
    taken: list[tuple[Any, list[tuple[str, Any]]]] = []
    try:
        for _ in range(count * 10):
            if len(taken) == count:
                break
            place = world.map.locations[rng.choice(furnished)]
            r, a = rng.uniform(0, 0.5), rng.uniform(-math.pi, math.pi)
            pose = Pose(place.x + r * math.cos(a), place.y + r * math.sin(a),
                        place.theta + rng.uniform(-0.5, 0.5))  # fmt: skip
            row, col = world.floor.grid.cell_of(pose.x, pose.y)
            if not world.floor.grid.free[row, col]:
                continue
            view = renderer.render(pose)
            truths = [
                (o.label, view.instances == o.index)
                for o in view.objects
                if int((view.instances == o.index).sum()) >= MIN_PIXELS
            ]
            if truths:
                camera.shot(pose)  # saved as robot-sim saves it: what the grounder reads
                taken.append((view.rgb, truths))
    finally:
        renderer.close()
    return taken


async def run(count: int, seed: int, directory: Path) -> dict[str, Any]:
    shots = views(count, seed, directory)
    ctx = PipelineContext(AnnotationGrounder(str(directory)), GrabCutSegmenter())
    ground_ious: list[float] = []
    ground_ms: list[float] = []
    all_ms: list[float] = []
    tp = fp = fn = 0
    matched: list[float] = []
    for rgb, truths in shots:
        for label, truth in truths:
            skill = Skill("find", "ground_and_segment", grounding=label, segment=True)
            t0 = time.perf_counter()
            result = await run_skill(skill, rgb, ctx)
            ground_ms.append(1000 * (time.perf_counter() - t0))
            ious = [mask_iou(d.mask, truth) for d in result.detections if d.mask is not None]
            ground_ious.append(max(ious, default=0.0))
        t0 = time.perf_counter()
        result = await run_skill(Skill("all", "segment_all", segment=True), rgb, ctx)
        all_ms.append(1000 * (time.perf_counter() - t0))
        pairs = sorted(
            (
                (mask_iou(d.mask, t), di, ti)
                for di, d in enumerate(result.detections)
                if d.mask is not None
                for ti, (_, t) in enumerate(truths)
            ),
            reverse=True,
        )
        used_d: set[int] = set()
        used_t: set[int] = set()
        for iou, di, ti in pairs:
            if iou >= IOU and di not in used_d and ti not in used_t:
                used_d.add(di)
                used_t.add(ti)
                matched.append(iou)
        tp += len(used_t)
        fp += len(result.detections) - len(used_d)
        fn += len(truths) - len(used_t)
    objects = len(ground_ious)
    return {
        "benchmark": "perception_sim",
        "world": "robot-sim office, MuJoCo 640x480 views around the named places",
        "grounder": "AnnotationGrounder (offline, the renderer's annotations)",
        "segmenter": "GrabCutSegmenter",
        "views": len(shots),
        "objects_in_view": objects,
        "seed": seed,
        "ground_and_segment": {
            "iou_median": round(statistics.median(ground_ious), 3) if ground_ious else None,
            "iou_p10": q(ground_ious, 10),
            "recall_at_iou_0.5": round(sum(i >= IOU for i in ground_ious) / max(objects, 1), 3),
            "ms_per_object_p50": q(ground_ms, 50),
            "ms_per_object_p95": q(ground_ms, 95),
        },
        "segment_all": {
            "precision": round(tp / (tp + fp), 3) if tp + fp else None,
            "recall": round(tp / (tp + fn), 3) if tp + fn else None,
            "matched_iou_median": round(statistics.median(matched), 3) if matched else None,
            "matched_iou_p10": q(matched, 10),
            "ms_per_frame_p50": q(all_ms, 50),
            "ms_per_frame_p95": q(all_ms, 95),
        },
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--views", type=int, default=40)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    structlog.configure(wrapper_class=structlog.make_filtering_bound_logger(logging.WARNING))
    with tempfile.TemporaryDirectory() as tmp:
        result = asyncio.run(run(args.views, args.seed, Path(tmp)))
    result["loadavg"] = Path("/proc/loadavg").read_text().split()[:3]
    RESULTS.parent.mkdir(parents=True, exist_ok=True)
    RESULTS.write_text(json.dumps(result, indent=2) + "\n")
    g, s = result["ground_and_segment"], result["segment_all"]
    print(
        f"{result['views']} office views, {result['objects_in_view']} objects in view. "
        f"ground_and_segment: IoU median {g['iou_median']}, p10 {g['iou_p10']}, "
        f"recall {g['recall_at_iou_0.5']}, {g['ms_per_object_p50']} ms/object. "
        f"segment_all: precision {s['precision']}, recall {s['recall']}, "
        f"matched IoU median {s['matched_iou_median']}, {s['ms_per_frame_p50']} ms/frame"
    )
    print(f"wrote {RESULTS}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
