"""CameraFeed over the vision node's artifacts server (``GET /frames/latest.jpg``).

The brain serves what this returns on the operator's origin, so only an image comes through:
an upstream answering anything else (e.g. ``text/html`` with a script), or more than
``max_bytes``, is treated as a camera that cannot deliver a frame. The node's pictures need
its credential (``ARTIFACTS_AUTH_TOKEN`` there, ``VISION_ARTIFACTS_TOKEN`` here), sent as
``Authorization: Bearer`` with the frame request only; its ``/healthz`` is open."""

from __future__ import annotations

import httpx
from pydantic import SecretStr

from robot_voice_chat.services.camera.base import (
    IMAGE_TYPES,
    CameraFeed,
    CameraFrame,
    CameraOfflineError,
    VisionHealth,
)

FRAME_PATH = "/frames/latest.jpg"
HEALTH_PATH = "/healthz"
DEFAULT_MAX_BYTES = 8 * 1024 * 1024


class HttpCameraFeed(CameraFeed):
    def __init__(
        self,
        base_url: str,
        timeout_s: float = 2.0,
        max_bytes: int = DEFAULT_MAX_BYTES,
        *,
        token: SecretStr | None = None,
    ) -> None:
        self.url = base_url.rstrip("/") + FRAME_PATH
        self._token = token
        self.max_bytes = max_bytes
        self.health_url = base_url.rstrip("/") + HEALTH_PATH
        self._client = httpx.AsyncClient(timeout=timeout_s)

    async def latest_frame(self) -> CameraFrame:
        headers = (
            {"Authorization": f"Bearer {self._token.get_secret_value()}"}
            if self._token is not None
            else {}
        )
        try:
            async with self._client.stream("GET", self.url, headers=headers) as response:
                if response.status_code == 401:
                    raise CameraOfflineError(
                        f"the vision node refused the brain's credential ({self.url}): set "
                        "VISION_ARTIFACTS_TOKEN to the node's ARTIFACTS_AUTH_TOKEN"
                    )
                if response.status_code != 200:
                    raise CameraOfflineError(
                        f"the vision node has no frame ({response.status_code} from {self.url})"
                    )
                media_type = response.headers.get("content-type", "").split(";")[0].strip()
                if media_type.lower() not in IMAGE_TYPES:
                    raise CameraOfflineError(
                        f"the vision node answered {media_type or 'no content type'!r}, "
                        f"not an image ({self.url})"
                    )
                data = await self._read_capped(response)
        except httpx.HTTPError as exc:
            raise CameraOfflineError(
                f"the vision node is not reachable ({self.url}): {exc}"
            ) from exc
        return CameraFrame(data, media_type.lower())

    async def _read_capped(self, response: httpx.Response) -> bytes:
        declared = response.headers.get("content-length", "")
        if declared.isdigit() and int(declared) > self.max_bytes:
            raise CameraOfflineError(self._too_large())
        chunks, size = [], 0
        async for chunk in response.aiter_bytes():
            size += len(chunk)
            if size > self.max_bytes:
                raise CameraOfflineError(self._too_large())
            chunks.append(chunk)
        return b"".join(chunks)

    def _too_large(self) -> str:
        return f"the vision node's frame is larger than {self.max_bytes} bytes ({self.url})"

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
