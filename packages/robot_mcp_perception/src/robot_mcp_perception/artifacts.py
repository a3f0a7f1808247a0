"""Artifacts HTTP endpoint (ARCHITECTURE §4.2): ``/healthz``, recent masks and overlays.

Masks travel on ROS; this endpoint only lets the UI / brain-side tools fetch a picture by
``mask_ref``. Memory is bounded: the last ``masks_per_skill`` results' masks are kept
bit-packed (≈38 KB per 640×480 mask) and the last ``overlays_per_skill`` overlays are kept as
(frame, result) and rendered to PNG on request. A deleted skill's artifacts stay addressable
until ``deleted_skills_kept`` later deletions: a planner typically reads a ``mask_ref`` and
stops the skill right after, and the reference must still resolve for whoever acts on it.

Routes (all GET, bound to 127.0.0.1). Every route but ``/healthz`` needs the credential of
:mod:`robot_mcp_perception.artifacts_auth` (``Authorization: Bearer <ARTIFACTS_AUTH_TOKEN>``;
401 with ``WWW-Authenticate`` otherwise):
- ``/healthz`` — the node's real state (frame age, models, skills); HTTP 503 unless
  ``status`` is ``ok``; open (no pixels, and readiness checks carry no credential);
- ``/skills/{skill}/masks`` — the kept mask refs of a skill;
- ``/masks/{skill}/{stamp_ns}/{index}.png`` — one mask (mono8 PNG);
- ``/overlays/{skill}/latest.png`` and ``/overlays/{skill}/{stamp_ns}.png``;
- ``/frames/latest.jpg`` — the newest camera frame with the newest overlay of every kept
  skill drawn on it (the operator UI's camera view, proxied by the brain): masks, boxes and
  labels, never the semantic outputs' text (the UI shows scene descriptions beside the image).
"""

from __future__ import annotations

import dataclasses
import io
import socket
import threading
import time
from collections import OrderedDict, deque
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
import structlog
import uvicorn
from PIL import Image as PILImage
from starlette.applications import Starlette
from starlette.middleware import Middleware
from starlette.requests import Request
from starlette.responses import JSONResponse, Response
from starlette.routing import Route
from starlette.types import ASGIApp, Receive, Scope, Send

from robot_mcp_perception.artifacts_auth import ArtifactsAuth
from robot_mcp_perception.frames import Frame
from robot_mcp_perception.models.base import Image
from robot_mcp_perception.pipelines.common import SkillResult
from robot_mcp_perception.settings import StartupError

logger = structlog.get_logger("robot_mcp_perception.artifacts")

OverlayRenderer = Callable[[Image, SkillResult], Image]
HealthProvider = Callable[[], dict[str, Any]]
LatestFrame = Callable[[], Frame | None]


@dataclass(frozen=True)
class _StoredMask:
    shape: tuple[int, int]
    bits: npt.NDArray[np.uint8]

    def to_png(self) -> bytes:
        count = self.shape[0] * self.shape[1]
        flat = np.unpackbits(self.bits, count=count).astype(bool)
        pixels = np.where(flat.reshape(self.shape), np.uint8(255), np.uint8(0))
        return _png(pixels.astype(np.uint8))


def _jpeg(pixels: Image | npt.NDArray[np.uint8], quality: int = 80) -> bytes:
    buffer = io.BytesIO()
    PILImage.fromarray(pixels).convert("RGB").save(buffer, format="JPEG", quality=quality)
    return buffer.getvalue()


def _png(pixels: Image | npt.NDArray[np.uint8]) -> bytes:
    buffer = io.BytesIO()
    PILImage.fromarray(pixels).save(buffer, format="PNG", compress_level=1)
    return buffer.getvalue()


class ArtifactStore:
    """Recent masks/overlays per skill (thread-safe, bounded)."""

    def __init__(
        self,
        base_url: str,
        masks_per_skill: int = 8,
        overlays_per_skill: int = 2,
        renderer: OverlayRenderer | None = None,
        deleted_skills_kept: int = 8,
    ) -> None:
        self.base_url = base_url.rstrip("/")
        self.masks_per_skill = masks_per_skill
        self.overlays_per_skill = overlays_per_skill
        self.renderer = renderer
        self.deleted_skills_kept = deleted_skills_kept
        self._retired: OrderedDict[str, None] = OrderedDict()
        self._masks: dict[str, OrderedDict[tuple[int, int], _StoredMask]] = {}
        self._overlays: dict[str, deque[tuple[int, Frame, SkillResult]]] = {}
        self._lock = threading.Lock()

    def mask_path(self, skill: str, stamp_ns: int, index: int) -> str:
        return f"/masks/{skill}/{stamp_ns}/{index}.png"

    def add(
        self, skill: str, topic: str, frame: Frame, result: SkillResult
    ) -> list[dict[str, Any]]:
        """Keep this result's masks/overlay; returns one ``mask_ref`` (or {}) per detection."""
        refs: list[dict[str, Any]] = []
        with self._lock:
            self._retired.pop(skill, None)
            masks = self._masks.setdefault(skill, OrderedDict())
            for index, detection in enumerate(result.detections):
                if detection.mask is None:
                    refs.append({})
                    continue
                mask = np.asarray(detection.mask, dtype=bool)
                masks[(frame.stamp_ns, index)] = _StoredMask(
                    (mask.shape[0], mask.shape[1]), np.packbits(mask)
                )
                path = self.mask_path(skill, frame.stamp_ns, index)
                refs.append(
                    {
                        "topic": topic,
                        "stamp": frame.stamp_ns / 1e9,
                        "stamp_ns": frame.stamp_ns,
                        "index": index,
                        "url": self.base_url + path,
                        "path": path,
                    }
                )
            stamps = list(dict.fromkeys(stamp for stamp, _ in masks))
            for old in stamps[: max(0, len(stamps) - self.masks_per_skill)]:
                for key in [k for k in masks if k[0] == old]:
                    del masks[key]
            overlays = self._overlays.setdefault(skill, deque(maxlen=self.overlays_per_skill))
            overlays.append((frame.stamp_ns, frame, result))
        return refs

    def retire(self, skill: str) -> None:
        """The skill was deleted: keep its artifacts until enough later deletions push it out."""
        with self._lock:
            self._retired.pop(skill, None)
            self._retired[skill] = None
            while len(self._retired) > self.deleted_skills_kept:
                oldest, _ = self._retired.popitem(last=False)
                self._drop(oldest)

    def _drop(self, skill: str) -> None:
        self._masks.pop(skill, None)
        self._overlays.pop(skill, None)

    def mask_png(self, skill: str, stamp_ns: int, index: int) -> bytes | None:
        with self._lock:
            stored = self._masks.get(skill, OrderedDict()).get((stamp_ns, index))
        return stored.to_png() if stored else None

    def mask_refs(self, skill: str) -> list[dict[str, Any]]:
        with self._lock:
            keys = list(self._masks.get(skill, OrderedDict()))
        return [
            {"stamp_ns": s, "index": i, "url": self.base_url + self.mask_path(skill, s, i)}
            for s, i in keys
        ]

    def overlay_png(self, skill: str, stamp_ns: int | None) -> bytes | None:
        with self._lock:
            kept = list(self._overlays.get(skill, ()))
        for stamp, frame, result in reversed(kept):
            if stamp_ns is None or stamp == stamp_ns:
                image = self.renderer(frame.image, result) if self.renderer else frame.image
                return _png(np.asarray(image, dtype=np.uint8))
        return None

    def live_view_jpeg(self, frame: Frame) -> bytes:
        """``frame`` with the newest result of every kept (not retired) skill drawn on it."""
        with self._lock:
            latest = [
                kept[-1][2]
                for skill, kept in self._overlays.items()
                if kept and skill not in self._retired
            ]
        image = frame.image
        if self.renderer is not None:
            for result in latest:
                image = self.renderer(image, dataclasses.replace(result, outputs={}))
        return _jpeg(np.asarray(image, dtype=np.uint8))

    def approx_bytes(self) -> int:
        with self._lock:
            return sum(m.bits.nbytes for per in self._masks.values() for m in per.values())


OPEN_PATHS = frozenset({"/healthz"})


class PictureAuthMiddleware:
    """Every request but :data:`OPEN_PATHS` must carry the credential; else 401 with
    ``WWW-Authenticate: Bearer realm="vision"`` and a JSON sentence saying what is missing."""

    def __init__(self, app: ASGIApp, auth: ArtifactsAuth) -> None:
        self.app = app
        self.auth = auth

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http" or scope.get("path") in OPEN_PATHS:
            await self.app(scope, receive, send)
            return
        request = Request(scope)
        verdict = self.auth.check(request.headers.get("authorization"))
        if verdict == "ok":
            await self.app(scope, receive, send)
            return
        client = request.client
        logger.warning(
            "artifacts_auth_rejected",
            reason=verdict,
            path=scope.get("path", ""),
            client=f"{client.host}:{client.port}" if client else None,
        )
        await _unauthorized(verdict)(scope, receive, send)


def _unauthorized(verdict: str) -> JSONResponse:
    challenge = 'Bearer realm="vision"'
    if verdict == "invalid":
        challenge += ', error="invalid_token"'
        body = {"error": "invalid_token", "detail": "this credential is not the vision node's."}
    elif verdict == "unconfigured":
        body = {
            "error": "unauthorized",
            "detail": "the vision node has no credential configured (ARTIFACTS_AUTH_TOKEN), "
            "so it serves no pictures.",
        }
    else:
        body = {
            "error": "unauthorized",
            "detail": "pictures need the vision node's credential: Authorization: Bearer <token>.",
        }
    return JSONResponse(body, status_code=401, headers={"WWW-Authenticate": challenge})


def build_app(
    store: ArtifactStore,
    health: HealthProvider,
    latest_frame: LatestFrame | None = None,
    *,
    auth: ArtifactsAuth,
) -> Starlette:
    async def healthz(request: Request) -> JSONResponse:
        payload = health()
        return JSONResponse(payload, status_code=200 if payload.get("status") == "ok" else 503)

    async def list_masks(request: Request) -> JSONResponse:
        skill = request.path_params["skill"]
        return JSONResponse({"skill": skill, "masks": store.mask_refs(skill)})

    async def mask(request: Request) -> Response:
        params = request.path_params
        png = store.mask_png(params["skill"], params["stamp_ns"], params["index"])
        return _png_or_404(png, "mask")

    async def overlay(request: Request) -> Response:
        params = request.path_params
        return _png_or_404(store.overlay_png(params["skill"], params.get("stamp_ns")), "overlay")

    async def live_view(request: Request) -> Response:
        frame = latest_frame() if latest_frame is not None else None
        if frame is None:
            return JSONResponse(
                {"error": "no_frame", "detail": "the camera has not delivered a frame yet."},
                status_code=503,
            )
        return Response(
            store.live_view_jpeg(frame),
            media_type="image/jpeg",
            headers={"Cache-Control": "no-store"},
        )

    return Starlette(
        routes=[
            Route("/frames/latest.jpg", live_view),
            Route("/healthz", healthz),
            Route("/skills/{skill}/masks", list_masks),
            Route("/masks/{skill}/{stamp_ns:int}/{index:int}.png", mask),
            Route("/overlays/{skill}/latest.png", overlay),
            Route("/overlays/{skill}/{stamp_ns:int}.png", overlay),
        ],
        middleware=[Middleware(PictureAuthMiddleware, auth=auth)],
    )


def _png_or_404(png: bytes | None, what: str) -> Response:
    if png is None:
        return JSONResponse(
            {"error": "not_found", "detail": f"that {what} is no longer kept (or never was)."},
            status_code=404,
        )
    return Response(png, media_type="image/png")


class ArtifactServer:
    """uvicorn in a daemon thread; ``stop`` returns within its timeout."""

    def __init__(self, app: Starlette, host: str, port: int) -> None:
        config = uvicorn.Config(app, host=host, port=port, log_level="warning", access_log=False)
        self._server = uvicorn.Server(config)
        self._socket: socket.socket | None = None
        self._thread = threading.Thread(target=self._serve, name="artifacts", daemon=True)
        self.host, self.port = host, port

    def _serve(self) -> None:
        self._server.run(sockets=[self._socket] if self._socket is not None else None)

    def start(self, timeout_s: float = 5.0) -> None:
        """Bind here (a busy port is a :class:`StartupError` naming it), then serve."""
        family = socket.AF_INET6 if ":" in self.host else socket.AF_INET
        sock = socket.socket(family, socket.SOCK_STREAM)
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            sock.bind((self.host, self.port))
        except OSError as error:
            sock.close()
            raise StartupError(
                f"the artifacts port {self.host}:{self.port} is not free ({error.strerror}): "
                "stop what uses it or set artifacts.port (PERCEPTION_CONFIG_OVERRIDES)"
            ) from error
        self._socket = sock
        self._thread.start()
        deadline = time.monotonic() + timeout_s
        while not self._server.started:
            if not self._thread.is_alive() or time.monotonic() > deadline:
                raise RuntimeError(
                    f"the artifacts server could not listen on {self.host}:{self.port}"
                )
            time.sleep(0.02)
        logger.info("artifacts_listening", url=f"http://{self.host}:{self.port}")

    def stop(self, timeout_s: float = 5.0) -> None:
        self._server.should_exit = True
        if self._thread.is_alive():
            self._thread.join(timeout=timeout_s)
        if self._socket is not None:
            self._socket.close()
