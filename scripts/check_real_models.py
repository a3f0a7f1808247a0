"""Integration check with the real models (spec 000 §9, not CI).

Runs a one-shot ``find_object("biggest package")`` ground_and_segment skill through the real
router on a sample frame, with the real Gemini Robotics-ER grounder (``GEMINI_API_KEY``) and,
when a checkpoint is available, the real SAM segmenter (``SAM_CHECKPOINT``, needs the
``[sam]`` extra); without a checkpoint GrabCut segments. Each part whose prerequisite is
missing is skipped with a clear message and exit code 0.

    GEMINI_API_KEY=... SAM_CHECKPOINT=~/models/sam2.1_b.pt \
        uv run python scripts/check_real_models.py [--frames DIR] [--model ID] [--device cuda]

Exit codes: 0 = passed or skipped, 1 = a real model answered implausibly or failed.
"""

from __future__ import annotations

import argparse
import asyncio
import os
import sys
import tempfile
from pathlib import Path

import cv2
import numpy as np

from robot_mcp_perception.models.base import ModelError, ModelUnavailableError, Segmenter
from robot_mcp_perception.models.gemini_er import DEFAULT_MODEL, GeminiERGrounder
from robot_mcp_perception.models.grabcut import GrabCutSegmenter
from robot_mcp_perception.pipelines import run_skill
from robot_mcp_perception.pipelines.common import PipelineContext
from robot_mcp_perception.sample_scenes import generate_scenes
from robot_mcp_perception.skills import Skill, SkillOutput
from robot_mcp_perception.viz import render_overlay

SKILL = Skill(
    "find_object",
    "ground_and_segment",
    grounding="the biggest package",
    segment=True,
    once=True,
    outputs=(SkillOutput("found", "boolean", "whether a package is visible"),),
)


def pick_frame(frames: Path) -> tuple[Path, np.ndarray]:
    """A frame whose annotation mentions a package (else the first readable frame)."""
    paths = sorted(frames.glob("*.png")) + sorted(frames.glob("*.jpg"))
    with_package = [
        p
        for p in paths
        if p.with_suffix(".json").exists() and "package" in p.with_suffix(".json").read_text()
    ]
    for path in with_package + paths:
        bgr = cv2.imread(str(path))
        if bgr is not None:
            return path, cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)
    raise SystemExit(f"no readable frame in {frames}")


def build_segmenter(device: str) -> Segmenter:
    checkpoint = os.environ.get("SAM_CHECKPOINT", "")
    if not checkpoint:
        print("SKIP SAM: SAM_CHECKPOINT is not set — segmenting with GrabCut instead")
        return GrabCutSegmenter()
    from robot_mcp_perception.models.sam import SamSegmenter

    try:
        return SamSegmenter(checkpoint, device=device)
    except ModelUnavailableError as exc:
        print(f"SKIP SAM: {exc} — segmenting with GrabCut instead")
        return GrabCutSegmenter()


async def check(frames: Path, model: str, device: str, out_dir: Path) -> int:
    key = os.environ.get("GEMINI_API_KEY", "")
    if not key:
        print(
            "SKIP: GEMINI_API_KEY is not set — nothing to check against the real Gemini ER (exit 0)"
        )
        return 0
    path, image = pick_frame(frames)
    grounder = GeminiERGrounder(api_key=key, model=model, thinking_budget=0, timeout_s=60.0)
    segmenter = build_segmenter(device)
    try:
        result = await run_skill(SKILL, image, PipelineContext(grounder, segmenter))
    except ModelError as exc:
        print(f"FAIL: the real model call failed: {exc}")
        return 1
    finally:
        await grounder.aclose()
    overlay = out_dir / f"check_real_models_{path.stem}.png"
    cv2.imwrite(str(overlay), cv2.cvtColor(render_overlay(image, result), cv2.COLOR_RGB2BGR))
    print(
        f"frame {path.name}: grounder {model}, segmenter {type(segmenter).__name__}; "
        f"timings {result.timings_ms}"
    )
    print(f"outputs {result.outputs}; overlay written to {overlay}")
    masked = [d for d in result.detections if d.mask is not None]
    for d in result.detections:
        area = int(d.mask.sum()) if d.mask is not None else 0
        print(
            f"  {d.label!r} score {d.score:.2f} box {d.box} point {d.point} "
            f"mask px {area} {d.extra}"
        )
    if not masked:
        print("FAIL: no detection with a plausible mask")
        return 1
    print("PASS: find_object yields a plausible mask")
    return 0


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--frames", type=Path, default=None, help="folder of frames (default: generated)"
    )
    parser.add_argument("--model", default=DEFAULT_MODEL)
    parser.add_argument("--device", default="cuda")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        frames = args.frames or Path(tmp) / "scenes"
        if args.frames is None:
            generate_scenes(frames, count=8)
        return asyncio.run(check(frames, args.model, args.device, Path(tempfile.gettempdir())))


if __name__ == "__main__":
    sys.exit(main())
