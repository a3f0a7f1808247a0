"""The scenes folder: every frame the camera publishes, saved with its annotation first.

This is the sim's half of the contract with the vision node's offline grounder
(``AnnotationGrounder``, see the README): before a frame is first published, its lossless
PNG and its annotation JSON (``sample_scenes`` format) are in this folder, named
``<place>-<sha256 of the RGB bytes, 16 hex>``. The grounder recognises a received frame by its
content and re-reads the folder when it changes, so it answers for exactly what the camera
showed — nothing travels beside the image, and a real camera simply has no annotations.
Files are written to a temporary name and renamed (PNG first, JSON last): a reader never
sees half a frame, and the JSON's presence means the PNG is complete.
"""

from __future__ import annotations

import hashlib
import json
import threading
import time
from dataclasses import dataclass
from pathlib import Path

import cv2
import structlog

from robot_sim.scenes import HEIGHT, WIDTH, Scene

logger = structlog.get_logger(__name__)


@dataclass(frozen=True)
class StoredFrame:
    name: str
    """``<place>-<digest16>``: the file stem of the PNG and the JSON."""
    data: bytes
    """rgb8 pixels, row-major, ready for ``sensor_msgs/Image.data``."""
    width: int = WIDTH
    height: int = HEIGHT


def frame_name(scene: Scene) -> str:
    digest = hashlib.sha256(scene.pixels.tobytes()).hexdigest()[:16]
    return f"{scene.key}-{digest}"


class SceneStore:
    """Writes each distinct scene once; hands back the bytes to publish."""

    def __init__(self, directory: Path) -> None:
        self.directory = directory
        self._lock = threading.Lock()
        self._saved: dict[str, StoredFrame] = {}

    def save(self, scene: Scene) -> StoredFrame:
        name = frame_name(scene)
        with self._lock:
            known = self._saved.get(name)
            if known is not None:
                return known
            started = time.perf_counter()
            self.directory.mkdir(parents=True, exist_ok=True)
            png = self.directory / f"{name}.png"
            bgr = cv2.cvtColor(scene.pixels, cv2.COLOR_RGB2BGR)
            ok, encoded = cv2.imencode(".png", bgr)
            if not ok:
                raise OSError(f"cannot encode {png.name} as PNG")
            _write_atomic(png, encoded.tobytes())
            doc = scene.annotation_doc(png.name)
            _write_atomic(self.directory / f"{name}.json", json.dumps(doc, indent=1).encode())
            frame = StoredFrame(name, scene.pixels.tobytes())
            self._saved[name] = frame
            logger.info(
                "scene_saved",
                frame=name,
                objects=[a["label"] for a in scene.annotations],
                duration_ms=round(1000 * (time.perf_counter() - started), 2),
            )
            return frame


def _write_atomic(path: Path, data: bytes) -> None:
    temporary = path.with_name(f".{path.name}.tmp")
    temporary.write_bytes(data)
    temporary.replace(path)
