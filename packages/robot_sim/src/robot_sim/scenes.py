"""What the camera sees: a deterministic top-down view of a place's surface and its objects,
with COCO-style annotations in the ``sample_scenes`` format the offline grounder reads.

Objects stand in six fixed slots (3 × 2, in the order the place lists them) and never overlap,
so each object's pixels are exactly its annotation polygon rasterised with ``cv2.fillPoly``.
A place's surface carries a texture seeded by the place's name: two places never look alike
(the grounder finds frames by content), and the same contents always give the same bytes.
"""

from __future__ import annotations

import zlib
from dataclasses import dataclass, field
from typing import Any

import cv2
import numpy as np
import numpy.typing as npt

from robot_sim.world import RGB, ObjectLook

WIDTH, HEIGHT = 640, 480
_COLS, _ROWS = 3, 2
CORRIDOR = "corridor"

Pixels = npt.NDArray[np.uint8]


@dataclass(frozen=True)
class Scene:
    """One camera view: RGB pixels (HEIGHT, WIDTH, 3) and what is in them."""

    key: str
    """The place name, or ``corridor``."""
    pixels: Pixels
    description: str
    annotations: list[dict[str, Any]] = field(default_factory=list)

    def annotation_doc(self, file_name: str) -> dict[str, Any]:
        """The ``sample_scenes`` annotation document for this frame saved as ``file_name``."""
        return {
            "image": {"file_name": file_name, "width": WIDTH, "height": HEIGHT},
            "source": "robot-sim",
            "place": self.key,
            "description": self.description,
            "annotations": self.annotations,
        }


def _seed(*parts: str) -> int:
    return zlib.crc32("/".join(parts).encode())


def _surface(colour: RGB, seed: int) -> npt.NDArray[np.float32]:
    """The surface colour with a low-frequency pattern, a lighting gradient and fine grain."""
    rng = np.random.default_rng(seed)
    coarse = rng.uniform(-1.0, 1.0, (6, 8)).astype(np.float32)
    pattern = cv2.resize(coarse, (WIDTH, HEIGHT), interpolation=cv2.INTER_CUBIC)
    light = np.linspace(0.92, 1.06, WIDTH, dtype=np.float32)[None, :]
    grain = rng.normal(0.0, 3.0, (HEIGHT, WIDTH)).astype(np.float32)
    base = np.asarray(colour, np.float32)[None, None, :]
    shade = (light * (1.0 + 0.14 * pattern))[:, :, None]
    return np.asarray(base * shade + grain[:, :, None], np.float32)


def _shape_mask(look: ObjectLook, size: int, rng: np.random.Generator) -> Pixels:
    """The object's silhouette, drawn upright in a (2·size)² canvas centred on it."""
    mask = np.zeros((2 * size, 2 * size), np.uint8)
    c = size
    s = size
    if look.shape == "mug":
        cv2.circle(mask, (c, c), int(0.55 * s), 255, -1)
        cv2.rectangle(
            mask,
            (c + int(0.45 * s), c - int(0.15 * s)),
            (c + int(0.85 * s), c + int(0.15 * s)),
            255,
            -1,
        )
    elif look.shape == "bottle":
        cv2.rectangle(
            mask,
            (c - int(0.25 * s), c - int(0.45 * s)),
            (c + int(0.25 * s), c + int(0.8 * s)),
            255,
            -1,
        )
        cv2.rectangle(
            mask,
            (c - int(0.1 * s), c - int(0.85 * s)),
            (c + int(0.1 * s), c - int(0.4 * s)),
            255,
            -1,
        )
    elif look.shape in ("parcel", "box"):
        w = int(s * (0.75 if look.shape == "parcel" else 0.6))
        h = int(s * (0.55 if look.shape == "parcel" else 0.6))
        cv2.rectangle(mask, (c - w, c - h), (c + w, c + h), 255, -1)
    elif look.shape == "plate":
        cv2.circle(mask, (c, c), int(0.75 * s), 255, -1)
    else:  # scissors: two blades and two finger loops
        cv2.line(
            mask, (c - int(0.7 * s), c - int(0.6 * s)), (c + int(0.3 * s), c + int(0.3 * s)), 255, 9
        )
        cv2.line(
            mask, (c + int(0.7 * s), c - int(0.6 * s)), (c - int(0.3 * s), c + int(0.3 * s)), 255, 9
        )
        cv2.circle(mask, (c - int(0.35 * s), c + int(0.55 * s)), int(0.22 * s), 255, -1)
        cv2.circle(mask, (c + int(0.35 * s), c + int(0.55 * s)), int(0.22 * s), 255, -1)
    angle = float(rng.uniform(-35.0, 35.0))
    turn = cv2.getRotationMatrix2D((float(c), float(c)), angle, 1.0)
    return np.asarray(cv2.warpAffine(mask, turn, (2 * s, 2 * s), flags=cv2.INTER_NEAREST), np.uint8)


def _polygon(silhouette: Pixels, offset: tuple[int, int]) -> npt.NDArray[np.int32]:
    contours, _ = cv2.findContours(silhouette, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
    outline = max(contours, key=cv2.contourArea).reshape(-1, 2)
    return np.asarray(outline + np.asarray(offset), np.int32)


def render_place(
    key: str, surface: RGB, description: str, objects: list[tuple[str, ObjectLook]]
) -> Scene:
    """The view of a place with ``objects`` (label, look) in slot order."""
    canvas = _surface(surface, _seed("surface", key))
    cell_w, cell_h = WIDTH // _COLS, HEIGHT // _ROWS
    annotations: list[dict[str, Any]] = []
    for slot, (label, look) in enumerate(objects):
        rng = np.random.default_rng(_seed("object", key, str(slot), label))
        size = int(min(cell_w, cell_h) * rng.uniform(0.30, 0.36))
        cx = (slot % _COLS) * cell_w + cell_w // 2 + int(rng.integers(-12, 13))
        cy = (slot // _COLS) * cell_h + cell_h // 2 + int(rng.integers(-12, 13))
        polygon = _polygon(_shape_mask(look, size, rng), (cx - size, cy - size))
        mask = np.zeros((HEIGHT, WIDTH), np.uint8)
        cv2.fillPoly(mask, [polygon], 1)
        inside = mask.astype(bool)
        shade = rng.normal(0.0, 4.0, (int(inside.sum()), 1)).astype(np.float32)
        canvas[inside] = np.asarray(look.colour, np.float32)[None, :] + shade
        x, y, w, h = cv2.boundingRect(polygon)
        annotations.append(
            {
                "id": slot + 1,
                "label": label,
                "bbox": [int(x), int(y), int(w), int(h)],
                "segmentation": [polygon.reshape(-1).tolist()],
                "area": int(inside.sum()),
                "difficulty": "easy",
            }
        )
    pixels = np.asarray(np.clip(canvas, 0, 255), np.uint8)
    return Scene(key, pixels, _describe(description, [label for label, _ in objects]), annotations)


def render_corridor(surface: RGB, description: str) -> Scene:
    """The view while driving: the corridor floor with its joint lines, nothing annotated."""
    canvas = _surface(surface, _seed("surface", CORRIDOR))
    for x in range(40, WIDTH, 120):
        cv2.line(canvas, (x, 0), (x + 60, HEIGHT), (80.0, 80.0, 86.0), 3)
    pixels = np.asarray(np.clip(canvas, 0, 255), np.uint8)
    return Scene(CORRIDOR, pixels, description)


def _describe(place: str, labels: list[str]) -> str:
    if not labels:
        return f"{place} Nothing stands there.".strip()
    counts: dict[str, int] = {}
    for label in labels:
        counts[label] = counts.get(label, 0) + 1
    things = [f"a {label}" if n == 1 else f"{n} {_plural(label)}" for label, n in counts.items()]
    listed = things[0] if len(things) == 1 else f"{', '.join(things[:-1])} and {things[-1]}"
    return f"{place} On it: {listed}.".strip()


def _plural(label: str) -> str:
    if label.endswith(("x", "ch", "sh")):
        return f"{label}es"
    return label if label.endswith("s") else f"{label}s"
