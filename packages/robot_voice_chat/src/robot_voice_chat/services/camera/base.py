"""The camera-feed port: the newest frame as an encoded image, or a clear offline error."""

from __future__ import annotations

import abc
from dataclasses import dataclass
from typing import Literal

# What a camera frame may be: the brain serves it on the operator's origin, never anything else.
IMAGE_TYPES = frozenset({"image/jpeg", "image/png", "image/webp"})


class CameraOfflineError(RuntimeError):
    """The camera source cannot deliver a frame now (node down, no frame yet)."""


@dataclass(frozen=True)
class CameraFrame:
    data: bytes
    media_type: str


VisionState = Literal["ok", "degraded", "unreachable"]


@dataclass(frozen=True)
class VisionHealth:
    """Whether the camera / vision node can see now (readyz, issue 23 item 5)."""

    state: VisionState
    detail: str = ""


class CameraFeed(abc.ABC):
    @abc.abstractmethod
    async def latest_frame(self) -> CameraFrame:
        """The newest frame with the overlays of running skills; raises CameraOfflineError."""

    async def health(self) -> VisionHealth:
        """Default: the camera is up when it can deliver a frame."""
        try:
            await self.latest_frame()
        except CameraOfflineError as exc:
            return VisionHealth("unreachable", str(exc))
        return VisionHealth("ok")

    async def aclose(self) -> None:  # noqa: B027 - optional hook
        """Release connections."""


class FakeCameraFeed(CameraFeed):
    """Serves the given frame, or is offline when there is none."""

    def __init__(self, frame: CameraFrame | None = None) -> None:
        self.frame = frame
        self.requests = 0

    async def latest_frame(self) -> CameraFrame:
        self.requests += 1
        if self.frame is None:
            raise CameraOfflineError("the fake camera has no frame")
        return self.frame
