"""A camera folder for tests that run the vision node on the generated sample scenes."""

from __future__ import annotations

import json
import shutil
from pathlib import Path


def frames_showing(
    scenes: Path,
    dest: Path,
    label: str,
    difficulty: str | None = "easy",
    limit: int | None = None,
) -> list[Path]:
    """Copy the sample frames (and annotations) in which ``label`` is plainly visible
    (annotated ``difficulty``, by default the clean ``easy`` case) to ``dest``. The hard cases
    (low contrast, touching objects) are for the benchmarks; GrabCut may reject their masks.
    ``limit=1`` gives a camera that stands still."""
    dest.mkdir(parents=True, exist_ok=True)
    copied: list[Path] = []
    for annotation in sorted(scenes.glob("*.json")):
        wanted = [
            a
            for a in json.loads(annotation.read_text())["annotations"]
            if a.get("label") == label and difficulty in (None, a.get("difficulty"))
        ]
        image = annotation.with_suffix(".png")
        if wanted and image.is_file():
            shutil.copyfile(annotation, dest / annotation.name)
            copied.append(Path(shutil.copyfile(image, dest / image.name)))
        if limit is not None and len(copied) >= limit:
            break
    return copied
