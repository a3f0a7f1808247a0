"""SAM and the on-board detector at speed (issue 30 items 5, 6): one prepared script for a lent GPU.

Builds random-weight checkpoints itself (the libraries' own builders and configs: quality
needs real weights, speed does not), then per model times load, first call, a new frame and
the same frame (decoder only) for 1, 5 and 20 box prompts (p50 / p90 over --repeats), and the
OWLv2 detector's frames per second; writes JSON to benchmarks/results/perception_gpu.json.
Models: ultralytics' SAM 2.1 tiny / base+ and SAM 3 (AGPL-3.0, ``segmenter=sam``) and the same
models through transformers (Apache-2.0, ``segmenter=hf_sam``): ``hf:sam2`` (SAM 2.1
Hiera-tiny) and ``hf:sam3_tracker`` (SAM 3).

    uv run python benchmarks/perception_gpu.py                      # GPU: native sizes, all models
    uv run python benchmarks/perception_gpu.py --smoke              # CPU smoke (make test runs it)
    uv run python benchmarks/perception_gpu.py --device cpu --models sam2.1_t.pt hf:sam2 --repeats 3

Needs the model libraries (scripts/install-model-libs.sh or the [sam]/[hf] extras).
"""

from __future__ import annotations

import argparse
import json
import shutil
import statistics
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from robot_mcp_perception.models import random_weights
from robot_mcp_perception.models.base import SegmentPrompt

RESULTS = Path(__file__).parent / "results" / "perception_gpu.json"


def frames(count: int, height: int, width: int) -> list[np.ndarray]:
    rng = np.random.default_rng(0)
    return [rng.integers(0, 255, (height, width, 3), dtype=np.uint8) for _ in range(count)]


def boxes(n: int, height: int, width: int) -> list[SegmentPrompt]:
    rng = np.random.default_rng(n)
    out = []
    for _ in range(n):
        x0, y0 = int(rng.integers(0, width // 2)), int(rng.integers(0, height // 2))
        out.append(SegmentPrompt(box=(x0, y0, x0 + width // 4, y0 + height // 4)))
    return out


def timed(fn: Any) -> float:
    started = time.perf_counter()
    fn()
    return 1000 * (time.perf_counter() - started)


def summary(samples: list[float]) -> dict[str, float]:
    ordered = sorted(samples)
    return {
        "p50_ms": round(statistics.median(ordered), 2),
        "p90_ms": round(ordered[min(len(ordered) - 1, int(0.9 * len(ordered)))], 2),
    }


def bench_sam(name: str, args: argparse.Namespace, work: Path) -> dict[str, Any]:
    """One model: ``sam2.1_t.pt`` … through ultralytics, ``hf:<family>`` through transformers."""
    from robot_mcp_perception.models.hf_sam import HfSamSegmenter
    from robot_mcp_perception.models.sam import SamSegmenter

    if name.startswith("hf:"):
        family = name.removeprefix("hf:")
        path = random_weights.hf_sam_folder(work / family, family, small=args.smoke)
        segmenter: Any = HfSamSegmenter
        library = "transformers (Apache-2.0)"
    else:
        path = random_weights.sam_checkpoint(work, name)
        segmenter = SamSegmenter
        library = "ultralytics (AGPL-3.0)"
    started = time.perf_counter()
    sam = segmenter(
        str(path), device=args.device, imgsz=args.imgsz.get(name), precision=args.precision
    )
    load_ms = 1000 * (time.perf_counter() - started)
    shots = frames(args.repeats + 2, args.height, args.width)
    first = timed(lambda: sam.segment_many(shots[0], boxes(1, args.height, args.width)))
    report: dict[str, Any] = {
        "library": library,
        "imgsz": sam.imgsz,
        "precision": sam.precision,
        "tf32": sam.tf32,
        "load_ms": round(load_ms, 1),
        "first_call_ms": round(first, 1),
    }
    for n in args.prompts:
        prompts = boxes(n, args.height, args.width)
        new = [
            timed(lambda f=f, p=prompts: sam.segment_many(f, p))
            for f in shots[1 : args.repeats + 1]
        ]
        same = [timed(lambda p=prompts: sam.segment_many(shots[args.repeats], p)) for _ in new]
        masks = sam.segment_many(shots[-1], prompts)
        report[f"{n}_prompts"] = {
            "new_frame": summary(new),
            "same_frame": summary(same),
            "masks": [len(masks), list(masks[0].shape)],
        }
    sam.close()
    if path.is_dir():
        shutil.rmtree(path)
    else:
        path.unlink()
    report["peak_gpu_mb"] = peak_gpu_mb()
    return report


def bench_owlv2(args: argparse.Namespace, work: Path) -> dict[str, Any]:
    import asyncio

    from robot_mcp_perception.models.owlv2 import Owlv2Grounder

    folder = random_weights.owlv2_folder(work / "owlv2", image_size=args.owl_size)
    started = time.perf_counter()
    grounder = Owlv2Grounder(str(folder), device=args.device, confidence=0.0)
    load_ms = 1000 * (time.perf_counter() - started)
    shots = frames(args.repeats, args.height, args.width)

    async def run() -> list[float]:
        await grounder.ground(shots[0], "a mug")  # first call
        return [
            1000 * (time.perf_counter() - t)
            for f in shots
            if (t := time.perf_counter()) and await grounder.ground(f, "a mug") is not None
        ]

    samples = asyncio.run(run())
    grounder.close()
    result = summary(samples)
    return {
        "image_size": args.owl_size,
        "load_ms": round(load_ms, 1),
        **result,
        "fps": round(1000 / result["p50_ms"], 2),
        "note": "random weights; real OWLv2 base is 960 px, ViT-B/16",
    }


def peak_gpu_mb() -> float | None:
    import torch

    if not torch.cuda.is_available():
        return None
    return round(torch.cuda.max_memory_allocated() / 2**20, 1)


ALL_MODELS = ["sam2.1_t.pt", "sam2.1_b.pt", "sam3.pt", "hf:sam2", "hf:sam3_tracker"]


def main(argv: list[str] | None = None) -> dict[str, Any]:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--smoke", action="store_true", help="CPU, small sizes, SAM 2.1 tiny")
    parser.add_argument("--device", default=None)
    parser.add_argument("--precision", default="auto")
    parser.add_argument("--repeats", type=int, default=10)
    parser.add_argument("--models", nargs="+", choices=ALL_MODELS, default=None)
    parser.add_argument("--no-owlv2", action="store_true", help="skip the detector")
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args(argv)
    import torch

    args.device = args.device or ("cuda" if torch.cuda.is_available() else "cpu")
    args.height, args.width = (120, 160) if args.smoke else (480, 640)
    args.prompts = [1, 5] if args.smoke else [1, 5, 20]
    args.repeats = 2 if args.smoke else args.repeats
    smoke_models = ["sam2.1_t.pt", "hf:sam2"]  # hf:sam2 smoke: a small config at 64 px
    models = args.models or (smoke_models if args.smoke else ALL_MODELS)
    args.imgsz = {"sam2.1_t.pt": 256} if args.smoke else {}
    args.owl_size = 64 if args.smoke else 960
    report: dict[str, Any] = {
        "device": args.device,
        "gpu": torch.cuda.get_device_name() if args.device.startswith("cuda") else None,
        "torch": torch.__version__,
        "smoke": args.smoke,
        "frame": [args.height, args.width],
        "models": {},
    }
    with tempfile.TemporaryDirectory() as tmp:
        for name in models:
            report["models"][name] = bench_sam(name, args, Path(tmp))
            print(name, json.dumps(report["models"][name]))
        if not args.no_owlv2:
            report["owlv2"] = bench_owlv2(args, Path(tmp))
            print("owlv2", json.dumps(report["owlv2"]))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(report, indent=2))
    print(f"wrote {args.out}")
    return report


if __name__ == "__main__":
    main()
