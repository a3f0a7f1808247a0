"""CameraFeed over the vision node's artifacts server (``GET /frames/latest.jpg``)."""

from __future__ import annotations

import httpx

from robot_voice_chat.services.camera.base import (
    CameraFeed,
    CameraFrame,
    CameraOfflineError,
    VisionHealth,
)

FRAME_PATH = "/frames/latest.jpg"
HEALTH_PATH = "/healthz"


class HttpCameraFeed(CameraFeed):
    def __init__(self, base_url: str, timeout_s: float = 2.0) -> None:
        self.url = base_url.rstrip("/") + FRAME_PATH
        self.health_url = base_url.rstrip("/") + HEALTH_PATH
        self._client = httpx.AsyncClient(timeout=timeout_s)

    async def latest_frame(self) -> CameraFrame:
        try:
            response = await self._client.get(self.url)
        except httpx.HTTPError as exc:
            raise CameraOfflineError(
                f"the vision node is not reachable ({self.url}): {exc}"
            ) from exc
        if response.status_code != 200:
            raise CameraOfflineError(
                f"the vision node has no frame ({response.status_code} from {self.url})"
            )
        media_type = response.headers.get("content-type", "image/jpeg").split(";")[0]
        return CameraFrame(response.content, media_type)

    async def health(self) -> VisionHealth:
        """The vision node's own ``/healthz`` (503 = degraded, e.g. no frames)."""
        try:
            response = await self._client.get(self.health_url)
        except httpx.HTTPError as exc:
            return VisionHealth(
                "unreachable", f"the vision node is not reachable ({self.health_url}): {exc}"
            )
        if response.status_code == 200:
            return VisionHealth("ok")
        return VisionHealth(
            "degraded",
            f"the vision node reports {response.status_code}: {response.text[:200]}",
        )

    async def aclose(self) -> None:
        await self._client.aclose()
