"""The scenes folder: every frame the camera publishes, saved with its annotation first.

This is the sim's half of the contract with the vision node's offline grounder
(``AnnotationGrounder``, see the README): before a frame is first published, its lossless
PNG and its annotation JSON (``sample_scenes`` format) are in this folder, named
``<place or room>-<sha256 of the RGB bytes, 16 hex>``. The grounder recognises a received
frame by its content and re-reads the folder when it changes, so it answers for exactly what
the camera showed — nothing travels beside the image, and a real camera simply has no
annotations. Files are written to a temporary name and renamed (PNG first, JSON last): a
reader never sees half a frame, and the JSON's presence means the PNG is complete.

The camera renders a new frame whenever the robot moved, so the folder is **bounded**: the
``keep`` frames published most recently stay (a frame published again, the robot standing
still, counts as new), older ones are deleted JSON first. At start the frames an earlier
robot-sim left (``"source": "robot-sim"``) are deleted.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import threading
import time
from collections import OrderedDict
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import numpy.typing as npt
import structlog

logger = structlog.get_logger(__name__)

SOURCE = "robot-sim"
DEFAULT_KEEP = 64


@dataclass(frozen=True)
class StoredFrame:
    name: str
    """``<place>-<digest16>``: the file stem of the PNG and the JSON."""
    data: bytes
    """rgb8 pixels, row-major, ready for ``sensor_msgs/Image.data``."""
    width: int
    height: int
    description: str = ""
    labels: tuple[str, ...] = ()
    """The objects annotated in it."""


def digest(pixels: npt.NDArray[np.uint8]) -> str:
    return hashlib.sha256(pixels.tobytes()).hexdigest()[:16]


class SceneStore:
    """Writes each distinct frame once; keeps the ``keep`` most recently published."""

    def __init__(self, directory: Path, keep: int = DEFAULT_KEEP) -> None:
        if keep < 1:
            raise ValueError("keep must be at least 1")
        self.directory = directory
        self.keep = keep
        self._lock = threading.Lock()
        self._saved: OrderedDict[str, StoredFrame] = OrderedDict()

    def clear_stale(self) -> int:
        """Delete the frames an earlier robot-sim left in the folder; how many."""
        removed = 0
        if not self.directory.is_dir():
            return 0
        for json_path in self.directory.glob("*.json"):
            try:
                doc = json.loads(json_path.read_text())
            except (OSError, ValueError):
                continue
            if isinstance(doc, dict) and doc.get("source") == SOURCE:
                _remove(json_path, self.directory / str(doc.get("image", {}).get("file_name", "")))
                removed += 1
        return removed

    def save(self, key: str, pixels: npt.NDArray[np.uint8], doc: dict[str, Any]) -> StoredFrame:
        """Save ``pixels`` (RGB) with ``doc`` (the annotation, less ``image``) unless the same
        frame is kept already; either way it becomes the most recently published."""
        name = f"{key}-{digest(pixels)}"
        with self._lock:
            known = self._saved.get(name)
            if known is not None:
                self._saved.move_to_end(name)
                return known
            started = time.perf_counter()
            self.directory.mkdir(parents=True, exist_ok=True)
            png = self.directory / f"{name}.png"
            ok, encoded = cv2.imencode(
                ".png", cv2.cvtColor(pixels, cv2.COLOR_RGB2BGR), [cv2.IMWRITE_PNG_COMPRESSION, 1]
            )
            if not ok:
                raise OSError(f"cannot encode {png.name} as PNG")
            _write_atomic(png, encoded.tobytes())
            height, width = int(pixels.shape[0]), int(pixels.shape[1])
            full = {
                "image": {"file_name": png.name, "width": width, "height": height},
                "source": SOURCE,
                **doc,
            }
            _write_atomic(self.directory / f"{name}.json", json.dumps(full).encode())
            labels = tuple(str(a["label"]) for a in doc.get("annotations", []))
            frame = StoredFrame(
                name, pixels.tobytes(), width, height, str(doc.get("description", "")), labels
            )
            self._saved[name] = frame
            while len(self._saved) > self.keep:
                old, _ = self._saved.popitem(last=False)
                _remove(self.directory / f"{old}.json", self.directory / f"{old}.png")
            logger.debug(
                "scene_saved",
                frame=name,
                objects=list(labels),
                duration_ms=round(1000 * (time.perf_counter() - started), 2),
            )
            return frame

    def touch(self, name: str) -> None:
        """``name`` is published again: it becomes the most recent (kept longest)."""
        with self._lock:
            if name in self._saved:
                self._saved.move_to_end(name)

    def names(self) -> list[str]:
        with self._lock:
            return list(self._saved)


def _remove(json_path: Path, image_path: Path) -> None:
    """The JSON first: a reader that sees a JSON always finds its image."""
    for path in (json_path, image_path):
        with contextlib.suppress(OSError):
            path.unlink()


def _write_atomic(path: Path, data: bytes) -> None:
    temporary = path.with_name(f".{path.name}.tmp")
    temporary.write_bytes(data)
    temporary.replace(path)
