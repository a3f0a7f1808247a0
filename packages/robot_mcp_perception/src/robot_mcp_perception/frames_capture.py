"""OpenCV VideoCapture frame sources: ``v4l2`` (a local camera) and ``rtsp`` (a stream).

A reader thread grabs frames as fast as the device delivers them and keeps only the latest.
When the device fails or the stream drops, it reconnects with exponential backoff
(``reconnect_initial_s`` doubling up to ``reconnect_max_s``) and logs ``frame_source_reconnect``.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, Protocol

import cv2
import numpy as np
import structlog

from robot_mcp_perception.frames import FrameListener, FrameSource, downscale

if TYPE_CHECKING:
    from rclpy.node import Node

logger = structlog.get_logger("robot_mcp_perception.frames")


class Capture(Protocol):
    """The part of ``cv2.VideoCapture`` the adapters use (fakes implement it in tests)."""

    def isOpened(self) -> bool: ...

    def read(self) -> tuple[bool, Any]: ...

    def release(self) -> None: ...


CaptureFactory = Callable[[], Capture]


class VideoCaptureFrameSource(FrameSource):
    """Base for the OpenCV sources; ``open_capture`` builds a fresh capture per (re)connect."""

    def __init__(
        self,
        open_capture: CaptureFactory,
        label: str,
        max_side: int = 1280,
        frame_id: str = "camera",
        reconnect_initial_s: float = 0.5,
        reconnect_max_s: float = 10.0,
    ) -> None:
        super().__init__(frame_id)
        self._open_capture = open_capture
        self.label = label
        self.max_side = max_side
        self.reconnect_initial_s = reconnect_initial_s
        self.reconnect_max_s = reconnect_max_s
        self.reconnects = 0
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    def start(self, node: Node | None, on_frame: FrameListener | None = None) -> None:
        self._listener = on_frame
        self._stop.clear()
        self._thread = threading.Thread(target=self._run, name="capture-frames", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=3.0)
            self._thread = None

    def _run(self) -> None:
        backoff = self.reconnect_initial_s
        while not self._stop.is_set():
            capture = self._open_capture()
            try:
                if capture.isOpened() and self._read_until_failure(capture):
                    backoff = self.reconnect_initial_s
            except Exception:  # loop boundary: a driver error must not kill the reader
                logger.exception("frame_source_failed", source=self.label)
            finally:
                capture.release()
            if self._stop.is_set():
                return
            self.reconnects += 1
            logger.warning("frame_source_reconnect", source=self.label, backoff_s=backoff)
            self._stop.wait(backoff)
            backoff = min(backoff * 2.0, self.reconnect_max_s)

    def _read_until_failure(self, capture: Capture) -> bool:
        """Read frames until the capture fails; True if at least one frame arrived."""
        got_any = False
        while not self._stop.is_set():
            ok, bgr = capture.read()
            if not ok or bgr is None:
                return got_any
            got_any = True
            rgb = np.ascontiguousarray(bgr[:, :, ::-1], dtype=np.uint8)
            self._emit(downscale(rgb, self.max_side))
        return got_any


class V4l2FrameSource(VideoCaptureFrameSource):
    def __init__(self, device: int | str = 0, width: int = 0, height: int = 0, **kwargs: Any):
        def open_capture() -> Capture:
            capture = cv2.VideoCapture(device, cv2.CAP_V4L2)
            if width and height:
                capture.set(cv2.CAP_PROP_FRAME_WIDTH, width)
                capture.set(cv2.CAP_PROP_FRAME_HEIGHT, height)
            capture.set(cv2.CAP_PROP_BUFFERSIZE, 1)
            return capture

        super().__init__(open_capture, label=f"v4l2:{device}", **kwargs)


class RtspFrameSource(VideoCaptureFrameSource):
    def __init__(self, url: str, **kwargs: Any) -> None:
        def open_capture() -> Capture:
            capture = cv2.VideoCapture(url, cv2.CAP_FFMPEG)
            capture.set(cv2.CAP_PROP_BUFFERSIZE, 1)
            return capture

        super().__init__(open_capture, label="rtsp", **kwargs)
