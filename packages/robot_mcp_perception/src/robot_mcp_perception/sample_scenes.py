"""Deterministic generator of synthetic tabletop scenes with COCO-style annotations.

Each frame ``scene_NNNN.png`` gets a ``scene_NNNN.json`` beside it::

    {"image": {"file_name", "width", "height"}, "seed", "description",
     "annotations": [{"id", "label", "bbox": [x, y, w, h], "segmentation": [[x1, y1, ...]],
                      "area", "difficulty": "easy" | "low_contrast" | "textured" | "touching"}]}

Objects never overlap, so every object's visible pixels are exactly the polygon rasterised by
:func:`polygon_mask` (``cv2.fillPoly`` of the integer polygon) — the ground truth for IoU
scoring. The same seed always gives byte-identical PNGs.

CLI: ``python -m robot_mcp_perception.sample_scenes OUT_DIR --count N --seed S``.
"""

from __future__ import annotations

import argparse
import json
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import numpy.typing as npt

Difficulty = str
DIFFICULTIES: tuple[Difficulty, ...] = ("easy", "low_contrast", "textured", "touching")

_COLOURS: dict[str, tuple[int, int, int]] = {
    "red mug": (200, 35, 40),
    "blue box": (40, 80, 200),
    "scissors": (70, 70, 80),
    "yellow package": (230, 200, 50),
    "green bottle": (40, 150, 70),
    "white plate": (240, 240, 235),
}
LABELS: tuple[str, ...] = tuple(_COLOURS)
_TABLES: tuple[tuple[int, int, int], ...] = ((150, 110, 75), (128, 128, 124), (176, 150, 118))
_TABLE_NAMES = ("wooden", "grey", "light oak")


@dataclass(frozen=True)
class _Placed:
    label: str
    polygon: npt.NDArray[np.int32]
    difficulty: Difficulty

    @property
    def bounds(self) -> tuple[int, int, int, int]:
        x0, y0 = self.polygon.min(axis=0)
        x1, y1 = self.polygon.max(axis=0)
        return int(x0), int(y0), int(x1), int(y1)


def polygon_mask(segmentation: Sequence[Sequence[float]], width: int, height: int) -> Any:
    """Boolean (height, width) mask of a COCO polygon list, rasterised like the generator."""
    canvas = np.zeros((height, width), np.uint8)
    polys = [
        np.round(np.asarray(p, np.float64).reshape(-1, 2)).astype(np.int32) for p in segmentation
    ]
    cv2.fillPoly(canvas, polys, 1)
    return canvas.astype(bool)


def _shape(label: str, size: float, rng: np.random.Generator) -> npt.NDArray[np.float64]:
    """Polygon of ``label`` centred on (0, 0), roughly ``size`` px across."""
    s = size
    if label == "red mug":
        body = [(-0.35, -0.45), (0.35, -0.45), (0.35, 0.4), (0.25, 0.5), (-0.25, 0.5), (-0.35, 0.4)]
        handle = [
            (0.35, -0.25),
            (0.55, -0.25),
            (0.6, -0.1),
            (0.6, 0.15),
            (0.55, 0.25),
            (0.35, 0.25),
        ]
        pts = [*body[:2], *handle, *body[2:]]
    elif label in ("blue box", "yellow package"):
        aspect = rng.uniform(0.55, 0.9)
        pts = [
            (-0.5, -0.5 * aspect),
            (0.5, -0.5 * aspect),
            (0.5, 0.5 * aspect),
            (-0.5, 0.5 * aspect),
        ]
    elif label == "scissors":
        pts = [
            (-0.5, -0.2),
            (-0.15, -0.22),
            (-0.05, -0.08),
            (0.5, -0.05),
            (0.5, 0.0),
            (0.0, 0.02),
            (0.5, 0.08),
            (0.48, 0.13),
            (-0.05, 0.1),
            (-0.15, 0.24),
            (-0.5, 0.22),
            (-0.42, 0.0),
        ]
    elif label == "green bottle":
        pts = [
            (-0.5, -0.18),
            (0.15, -0.18),
            (0.3, -0.08),
            (0.5, -0.08),
            (0.5, 0.08),
            (0.3, 0.08),
            (0.15, 0.18),
            (-0.5, 0.18),
        ]
    else:  # white plate: a circle
        angles = np.linspace(0.0, 2 * math.pi, 32, endpoint=False)
        pts = [(0.5 * math.cos(a), 0.5 * math.sin(a)) for a in angles]
    return np.asarray(pts, np.float64) * s


def _rotate(poly: npt.NDArray[np.float64], angle: float) -> npt.NDArray[np.float64]:
    c, s = math.cos(angle), math.sin(angle)
    rot = np.asarray([[c, -s], [s, c]])
    return np.asarray(poly @ rot.T, np.float64)


def _overlaps(b: tuple[int, int, int, int], others: list[_Placed], gap: int) -> bool:
    for o in others:
        ox0, oy0, ox1, oy1 = o.bounds
        if b[0] <= ox1 + gap and ox0 <= b[2] + gap and b[1] <= oy1 + gap and oy0 <= b[3] + gap:
            return True
    return False


def _place(
    rng: np.random.Generator,
    width: int,
    height: int,
    labels: list[str],
    difficulties: list[Difficulty],
) -> list[_Placed]:
    placed: list[_Placed] = []
    scale = min(width, height)
    margin = max(4, scale // 40)
    for label, difficulty in zip(labels, difficulties, strict=True):
        for _attempt in range(200):
            size = rng.uniform(0.2, 0.34) * scale
            angle = 0.0 if difficulty == "touching" else rng.uniform(-math.pi, math.pi)
            poly = _rotate(_shape(label, size, rng), angle)
            pmin, pmax = poly.min(axis=0), poly.max(axis=0)
            if difficulty == "touching" and placed and placed[-1].difficulty == "touching":
                # Glue to the right edge of the previous object, one pixel apart (no overlap).
                _px0, py0, px1, py1 = placed[-1].bounds
                cx = px1 + 1 - pmin[0]
                cy = 0.5 * (py0 + py1) + rng.uniform(-0.2, 0.2) * (py1 - py0)
            else:
                cx = rng.uniform(margin - pmin[0], width - margin - pmax[0])
                cy = rng.uniform(margin - pmin[1], height - margin - pmax[1])
            ipoly = np.round(poly + np.asarray([cx, cy])).astype(np.int32)
            candidate = _Placed(label, ipoly, difficulty)
            x0, y0, x1, y1 = candidate.bounds
            if x0 < margin or y0 < margin or x1 >= width - margin or y1 >= height - margin:
                continue
            others = placed[:-1] if difficulty == "touching" and placed else placed
            gap = 0 if difficulty == "touching" else margin
            if _overlaps(candidate.bounds, others, gap):
                continue
            placed.append(candidate)
            break
    return placed


def _table(rng: np.random.Generator, width: int, height: int, colour: tuple[int, int, int]) -> Any:
    yy = np.arange(height, dtype=np.float32)[:, None]
    xx = np.arange(width, dtype=np.float32)[None, :]
    phase = rng.uniform(0, 2 * math.pi)
    grain = 6.0 * np.sin(yy / rng.uniform(5.0, 9.0) + 0.8 * np.sin(xx / 60.0 + phase))
    light = 10.0 * (xx / width - 0.5) + 6.0 * (yy / height - 0.5)
    noise = rng.normal(0.0, 4.0, (height, width)).astype(np.float32)
    return (grain + light + noise)[:, :, None] + np.asarray(colour, np.float32)[None, None, :]


def _paint(
    canvas: Any,
    obj: _Placed,
    table_colour: tuple[int, int, int],
    rng: np.random.Generator,
) -> None:
    x0, y0, x1, y1 = obj.bounds
    h, w = y1 - y0 + 1, x1 - x0 + 1
    local = np.zeros((h, w), np.uint8)
    cv2.fillPoly(local, [obj.polygon - (x0, y0)], 1)
    sel = local.astype(bool)
    colour = np.asarray(_COLOURS[obj.label], np.float32)
    table = np.asarray(table_colour, np.float32)
    if obj.difficulty == "low_contrast":
        colour = table + (colour - table) * 0.4
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    shade = 14.0 * ((xx / max(w, 1)) - 0.5) - 8.0 * ((yy / max(h, 1)) - 0.5)
    pixels = colour[None, None, :] + shade[:, :, None]
    if obj.difficulty == "textured":
        period = rng.uniform(6.0, 10.0)
        stripes = (np.sin((xx + yy) / period * math.pi) > 0).astype(np.float32)
        pixels = pixels + stripes[:, :, None] * (0.45 * (255.0 - colour) - 0.35 * colour)
    pixels = pixels + rng.normal(0.0, 3.0, (h, w, 1)).astype(np.float32)
    region = canvas[y0 : y1 + 1, x0 : x1 + 1]
    region[sel] = pixels[sel]


def _shadow(canvas: Any, objects: list[_Placed], width: int, height: int) -> None:
    shadow = np.zeros((height, width), np.uint8)
    offset = max(2, min(width, height) // 80)
    cv2.fillPoly(shadow, [o.polygon + np.asarray([offset, offset]) for o in objects], 255)
    soft = cv2.GaussianBlur(shadow, (0, 0), offset).astype(np.float32) / 255.0
    canvas *= (1.0 - 0.12 * soft)[:, :, None]


def _count_phrase(label: str, n: int) -> str:
    if label == "scissors":
        return "a pair of scissors" if n == 1 else f"{n} pairs of scissors"
    return f"a {label}" if n == 1 else f"{n} {label}s"


def _describe(objects: list[_Placed], table_name: str) -> str:
    counts: dict[str, int] = {}
    for o in objects:
        counts[o.label] = counts.get(o.label, 0) + 1
    parts = [_count_phrase(label, n) for label, n in counts.items()]
    if not parts:
        return f"An empty {table_name} table seen from above."
    listing = parts[0] if len(parts) == 1 else ", ".join(parts[:-1]) + " and " + parts[-1]
    return f"A {table_name} table seen from above with {listing}."


def render_scene(
    index: int, seed: int = 0, size: tuple[int, int] = (640, 480)
) -> tuple[Any, dict[str, Any]]:
    """Render scene ``index`` of a seeded set: (RGB uint8 image, annotation dict)."""
    width, height = size
    rng = np.random.default_rng([seed, index])
    kind = DIFFICULTIES[index % len(DIFFICULTIES)]
    count = int(rng.integers(3, 6))
    labels = [str(x) for x in rng.choice(LABELS, size=count, replace=count > len(LABELS))]
    difficulties: list[Difficulty] = ["easy"] * count
    if kind == "touching":
        pair = ("blue box", "yellow package")
        labels = [*pair, *[lb for lb in labels if lb not in pair]][:count]
        difficulties[0] = difficulties[1] = "touching"
    elif kind != "easy":
        for i in range(min(2, count)):
            difficulties[i] = kind
    t = int(rng.integers(0, len(_TABLES)))
    objects = _place(rng, width, height, labels, difficulties)
    canvas = _table(rng, width, height, _TABLES[t])
    _shadow(canvas, objects, width, height)
    for obj in objects:
        _paint(canvas, obj, _TABLES[t], rng)
    image = np.clip(canvas, 0, 255).astype(np.uint8)
    annotations = []
    for i, obj in enumerate(objects, start=1):
        x0, y0, x1, y1 = obj.bounds
        flat = [int(v) for v in obj.polygon.reshape(-1)]
        area = int(polygon_mask([flat], width, height).sum())
        annotations.append(
            {
                "id": i,
                "label": obj.label,
                "bbox": [x0, y0, x1 - x0 + 1, y1 - y0 + 1],
                "segmentation": [flat],
                "area": area,
                "difficulty": obj.difficulty,
            }
        )
    doc = {
        "image": {"file_name": f"scene_{index:04d}.png", "width": width, "height": height},
        "seed": seed,
        "description": _describe(objects, _TABLE_NAMES[t]),
        "annotations": annotations,
    }
    return image, doc


def generate_scenes(
    out_dir: Path, count: int = 24, seed: int = 0, size: tuple[int, int] = (640, 480)
) -> list[Path]:
    """Write ``count`` scenes (PNG + JSON) into ``out_dir``; returns the PNG paths."""
    if count < 1:
        raise ValueError(f"count must be >= 1, got {count}")
    if size[0] < 64 or size[1] < 48:
        raise ValueError(f"size must be at least 64x48, got {size[0]}x{size[1]}")
    out_dir.mkdir(parents=True, exist_ok=True)
    paths: list[Path] = []
    for index in range(count):
        image, doc = render_scene(index, seed, size)
        png = out_dir / doc["image"]["file_name"]
        ok, encoded = cv2.imencode(".png", cv2.cvtColor(image, cv2.COLOR_RGB2BGR))
        if not ok:  # pragma: no cover - OpenCV always encodes uint8 BGR
            raise RuntimeError(f"could not encode {png}")
        png.write_bytes(encoded.tobytes())
        png.with_suffix(".json").write_text(json.dumps(doc, indent=1) + "\n")
        paths.append(png)
    return paths


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    parser.add_argument("out_dir", type=Path)
    parser.add_argument("--count", type=int, default=24)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--width", type=int, default=640)
    parser.add_argument("--height", type=int, default=480)
    args = parser.parse_args(argv)
    paths = generate_scenes(args.out_dir, args.count, args.seed, (args.width, args.height))
    print(f"wrote {len(paths)} scenes to {args.out_dir}")  # noqa: T201
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
