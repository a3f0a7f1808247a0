"""FrameSource port (spec 000 §4) and the folder adapter.

A frame source keeps only the *latest* frame: the node always processes the newest image and
never queues old ones. Adapters call ``on_frame`` for every new frame (from their own thread or
a ROS callback) and expose ``latest()``.

Adapters: :class:`FolderFrameSource` (here; dev/CI), ``frames_capture.{V4l2,Rtsp}FrameSource``
(OpenCV VideoCapture) and ``frames_ros.RosFrameSource`` (camera topic).
"""

from __future__ import annotations

import itertools
import threading
import time
from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import structlog
from PIL import Image as PILImage
from PIL import ImageOps, UnidentifiedImageError

from robot_mcp_perception.models.base import Image

if TYPE_CHECKING:
    from rclpy.node import Node

logger = structlog.get_logger("robot_mcp_perception.frames")

IMAGE_SUFFIXES = frozenset({".png", ".jpg", ".jpeg", ".bmp", ".webp"})
FrameListener = Callable[["Frame"], None]


@dataclass(frozen=True)
class Frame:
    image: Image
    """RGB uint8 (H, W, 3)."""
    stamp_ns: int
    """Source stamp (the camera header's stamp, or capture wall time)."""
    frame_id: str
    seq: int
    """Increases by one per frame of this source."""


class FrameSourceError(RuntimeError):
    """A frame source cannot start (missing folder, unusable device)."""


class FrameSource(ABC):
    """Yields the latest EXIF-corrected, downscaled RGB frame."""

    def __init__(self, frame_id: str = "camera") -> None:
        self.frame_id = frame_id
        self._latest: Frame | None = None
        self._latest_at: float | None = None
        self._lock = threading.Lock()
        self._seq = itertools.count(1)
        self._listener: FrameListener | None = None

    @abstractmethod
    def start(self, node: Node | None, on_frame: FrameListener | None = None) -> None:
        """Begin producing frames; ``node`` is only used by ROS-backed sources."""

    @abstractmethod
    def stop(self) -> None:
        """Stop producing frames and release devices (bounded time)."""

    def latest(self) -> Frame | None:
        with self._lock:
            return self._latest

    def latest_age_s(self) -> float | None:
        """Seconds since the newest frame arrived (monotonic clock; None before the first)."""
        with self._lock:
            at = self._latest_at
        return None if at is None else time.monotonic() - at

    def _emit(
        self, image: Image, stamp_ns: int | None = None, frame_id: str | None = None
    ) -> Frame:
        frame = Frame(
            image=image,
            stamp_ns=time.time_ns() if stamp_ns is None else stamp_ns,
            frame_id=frame_id or self.frame_id,
            seq=next(self._seq),
        )
        with self._lock:
            self._latest = frame
            self._latest_at = time.monotonic()
        if self._listener is not None:
            self._listener(frame)
        return frame


def downscale(image: Image, max_side: int) -> Image:
    """Shrink so the longer side is at most ``max_side`` (aspect kept); never upscales."""
    height, width = image.shape[:2]
    longest = max(height, width)
    if max_side <= 0 or longest <= max_side:
        return image
    scale = max_side / longest
    size = (max(1, round(width * scale)), max(1, round(height * scale)))
    resized = PILImage.fromarray(image).resize(size, PILImage.Resampling.BILINEAR)
    return np.asarray(resized, dtype=np.uint8)


def load_image(path: Path, max_side: int) -> Image:
    """Decode, apply the EXIF orientation, convert to RGB and downscale.

    Raises ``OSError``/``ValueError`` for unreadable or corrupt files.
    """
    with PILImage.open(path) as opened:
        upright = ImageOps.exif_transpose(opened)
        rgb = upright.convert("RGB")
    return downscale(np.asarray(rgb, dtype=np.uint8), max_side)


def list_images(directory: Path) -> list[Path]:
    return sorted(
        p for p in directory.iterdir() if p.is_file() and p.suffix.lower() in IMAGE_SUFFIXES
    )


class FolderFrameSource(FrameSource):
    """Loops over the images of a directory at ``fps``; corrupt files are skipped with a WARN."""

    def __init__(
        self,
        directory: str,
        fps: float = 2.0,
        max_side: int = 1280,
        loop: bool = True,
        frame_id: str = "camera",
        cache_frames: int = 32,
    ) -> None:
        super().__init__(frame_id)
        self.directory = Path(directory)
        self.fps = fps
        self.max_side = max_side
        self.loop = loop
        self._cache_frames = cache_frames
        self._cache: dict[Path, Image] = {}
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self.skipped: list[Path] = []

    def check(self) -> list[Path]:
        """The images to play, or :class:`FrameSourceError` with a fix-it message."""
        if not self.directory.is_dir():
            raise FrameSourceError(
                f"frame folder {self.directory} does not exist. Generate the sample scenes with "
                f"`uv run python -m robot_mcp_perception.sample_scenes {self.directory}` or set "
                "PERCEPTION_FRAMES_DIR / frame_source.directory."
            )
        images = list_images(self.directory)
        if not images:
            raise FrameSourceError(
                f"frame folder {self.directory} holds no images "
                f"({', '.join(sorted(IMAGE_SUFFIXES))})."
            )
        return images

    def start(self, node: Node | None, on_frame: FrameListener | None = None) -> None:
        images = self.check()
        self._listener = on_frame
        self._stop.clear()
        self._thread = threading.Thread(
            target=self._run, args=(images,), name="folder-frames", daemon=True
        )
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
            self._thread = None

    def read(self, path: Path) -> Image | None:
        """The decoded frame, or None (WARN ``frame_skipped``) if the file is unusable."""
        cached = self._cache.get(path)
        if cached is not None:
            return cached
        try:
            image = load_image(path, self.max_side)
        except (OSError, ValueError, UnidentifiedImageError) as error:
            logger.warning("frame_skipped", path=str(path), error=str(error))
            self.skipped.append(path)
            return None
        if len(self._cache) < self._cache_frames:
            self._cache[path] = image
        return image

    def _run(self, images: list[Path]) -> None:
        period = 1.0 / self.fps if self.fps > 0 else 0.5
        next_at = time.monotonic()
        while not self._stop.is_set():
            shown = 0
            for path in images:
                if self._stop.is_set():
                    return
                image = self.read(path)
                if image is None:
                    continue
                self._emit_safely(image)
                shown += 1
                next_at += period
                self._stop.wait(max(0.0, next_at - time.monotonic()))
                next_at = max(next_at, time.monotonic() - period)
            if not self.loop:
                return
            if shown == 0:
                logger.warning("frame_folder_unusable", directory=str(self.directory))
                self._stop.wait(1.0)
            images = list_images(self.directory) or images

    def _emit_safely(self, image: Image) -> None:
        try:
            self._emit(image)
        except Exception:  # loop boundary: a listener bug must not kill the frame thread
            logger.exception("frame_listener_failed")


def describe_source(source: FrameSource) -> dict[str, Any]:
    latest = source.latest()
    return {
        "type": type(source).__name__,
        "frame_id": source.frame_id,
        "last_seq": latest.seq if latest else None,
    }
