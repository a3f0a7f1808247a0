"""The offline grounder's annotation of a rendered view, read from the renderer's
segmentation: every object with at least ``MIN_PIXELS`` visible pixels gets its outline(s)
(the visible part; an object half behind another is half annotated), box and pixel area, in
the ``sample_scenes`` format. The description says where the robot is and what is in view.
"""

from __future__ import annotations

from typing import Any

import cv2
import numpy as np

from robot_sim.render.renderer import RenderedView

MIN_PIXELS = 60
"""Fewer visible pixels than this and an object counts as not in view (a few pixels at the
frame's edge, or a sliver behind another object)."""


def annotate_view(view: RenderedView) -> list[dict[str, Any]]:
    found: list[dict[str, Any]] = []
    for placed in view.objects:
        mask = np.asarray(view.instances == placed.index, np.uint8)
        area = int(mask.sum())
        if area < MIN_PIXELS:
            continue
        contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
        polygons = [c.reshape(-1).tolist() for c in contours if len(c) >= 3]
        if not polygons:
            continue
        x, y, w, h = cv2.boundingRect(mask)
        found.append(
            {
                "id": placed.index,
                "label": placed.label,
                "bbox": [int(x), int(y), int(w), int(h)],
                "segmentation": polygons,
                "area": area,
                "place": placed.place,
                "difficulty": "easy",
            }
        )
    return found


def describe(where: str, labels: list[str]) -> str:
    """ "The kitchen counter. In view: a red mug and 2 cardboard boxes." """
    if not labels:
        return f"{where} No objects in view.".strip()
    counts: dict[str, int] = {}
    for label in labels:
        counts[label] = counts.get(label, 0) + 1
    things = [f"a {label}" if n == 1 else f"{n} {_plural(label)}" for label, n in counts.items()]
    listed = things[0] if len(things) == 1 else f"{', '.join(things[:-1])} and {things[-1]}"
    return f"{where} In view: {listed}.".strip()


def _plural(label: str) -> str:
    if label.endswith(("x", "ch", "sh")):
        return f"{label}es"
    return label if label.endswith("s") else f"{label}s"
