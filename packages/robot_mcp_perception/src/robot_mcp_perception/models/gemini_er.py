"""GeminiERGrounder: Gemini Robotics-ER through the google-genai SDK (cloud; metered, §8).

One ``generateContent`` call per question: the frame as an inline JPEG + the prompt of
:mod:`robot_mcp_perception.prompt_builder`, JSON response mode, and thinking on (spec 000
§4): ``thinking_budget`` tokens (default :data:`DEFAULT_THINKING_BUDGET`; 0 turns thinking
off, -1 lets the model decide) or a ``thinking_level`` (LOW/HIGH… for models that take
levels) — never both, the API refuses that. Gemini ER answers points ``[y, x]`` and boxes
``box_2d [ymin, xmin, ymax, xmax]`` normalized to 0–1000; they are converted to pixels of
the received image here (so are ``position`` / ``pose`` outputs, which become pixel
``{"x", "y"}``; a position answered as a ``[y, x]`` list is read in that order).

Failures: transient ones (HTTP 408/429/5xx, timeouts, connection errors) are retried
``retries`` times with exponential backoff (each retry is charged to the cloud budget), then
raised as :class:`ModelError`; other HTTP errors raise at once (401/403 and a 400
``API_KEY_INVALID`` as :class:`ModelUnavailableError`, also reported by :meth:`readiness`
until a call succeeds); an unusable answer raises
:class:`~robot_mcp_perception.prompt_builder.BadModelAnswerError`. An empty API key is
refused at construction (start-up). One call takes at most :attr:`worst_case_s`.
"""

from __future__ import annotations

import asyncio
import importlib
import re
import time
from typing import Any

import cv2
import httpx
import structlog
from google import genai
from google.genai import errors as genai_errors
from google.genai import types
from pydantic import SecretStr

from robot_mcp_perception.models._checks import check_image
from robot_mcp_perception.models.base import (
    CostClass,
    FailureKind,
    GroundedTarget,
    Grounder,
    GroundingResult,
    Image,
    ModelError,
    ModelUnavailableError,
    SemanticRequest,
)
from robot_mcp_perception.models.metering import charge_cloud_request
from robot_mcp_perception.prompt_builder import (
    BadModelAnswerError,
    build_point_prompt,
    build_prompt,
    extract_json,
    parse_results,
)

log = structlog.get_logger(__name__)

DEFAULT_MODEL = "gemini-robotics-er-2-preview"
DEFAULT_THINKING_BUDGET = 1024
"""Thinking on (spec 000), bounded so a pointing answer stays within seconds."""
THINKING_LEVELS = frozenset(level.value for level in types.ThinkingLevel) - {
    "THINKING_LEVEL_UNSPECIFIED"
}
_RETRYABLE = {408, 429, 500, 502, 503, 504}


def _transport_errors() -> tuple[type[BaseException], ...]:
    """Connection/timeout errors of the HTTP client the SDK uses (httpx2 by default, httpx
    on request) — both are covered."""
    found: list[type[BaseException]] = [TimeoutError]
    for name in ("httpx2", "httpx"):
        try:
            found.append(importlib.import_module(name).TransportError)
        except (ImportError, AttributeError):  # pragma: no cover - depends on the install
            continue
    return tuple(found)


_TRANSPORT_ERRORS = _transport_errors()


class GeminiERGrounder(Grounder):
    cost_class: CostClass = "cloud"

    def __init__(
        self,
        api_key: str | SecretStr,
        model: str = DEFAULT_MODEL,
        thinking_budget: int | None = DEFAULT_THINKING_BUDGET,
        thinking_level: str | None = None,
        timeout_s: float = 20.0,
        retries: int = 2,
        retry_backoff_s: float = 1.0,
        temperature: float = 0.5,
        jpeg_quality: int = 90,
        max_targets: int = 20,
        base_url: str | None = None,
    ) -> None:
        key = api_key if isinstance(api_key, SecretStr) else SecretStr(api_key or "")
        if not key.get_secret_value().strip():
            raise ModelUnavailableError(
                "GEMINI_API_KEY is empty: the gemini_er grounder needs a key (set GEMINI_API_KEY "
                "in the environment or .env), or select grounder=annotation for offline use"
            )
        if not model:
            raise ValueError("model id must not be empty")
        if timeout_s <= 0 or retries < 0 or retry_backoff_s < 0:
            raise ValueError("timeout_s must be > 0, retries and retry_backoff_s >= 0")
        if not 1 <= jpeg_quality <= 100:
            raise ValueError(f"jpeg_quality must be in 1..100, got {jpeg_quality}")
        if thinking_budget is not None and thinking_level is not None:
            raise ValueError("set thinking_budget or thinking_level, not both (the API refuses)")
        level = thinking_level.upper() if thinking_level is not None else None
        if level is not None and level not in THINKING_LEVELS:
            raise ValueError(
                f"thinking_level must be one of {', '.join(sorted(THINKING_LEVELS))}, "
                f"got {thinking_level!r}"
            )
        self.model = model
        self.thinking_budget = thinking_budget
        self.thinking_level = level
        self._problem: str | None = None
        self.timeout_s = timeout_s
        self.retries = retries
        self.retry_backoff_s = retry_backoff_s
        self.temperature = temperature
        self.jpeg_quality = jpeg_quality
        self.max_targets = max_targets
        self._api_key = key
        # Our own httpx client: without one, google-genai switches its async transport to
        # aiohttp whenever aiohttp happens to be importable, so behaviour (and errors) would
        # depend on unrelated packages in the environment.
        self._http = httpx.AsyncClient(timeout=timeout_s)
        self._client = genai.Client(
            api_key=key.get_secret_value(),
            http_options=types.HttpOptions(
                base_url=base_url,
                api_version="v1beta",
                timeout=int(timeout_s * 1000),
                retry_options=types.HttpRetryOptions(attempts=1),  # retries are ours
                httpx_async_client=self._http,
            ),
        )

    @property
    def worst_case_s(self) -> float:
        """Every attempt timing out, plus the backoff sleeps between them."""
        backoff = sum(self.retry_backoff_s * 2**k for k in range(self.retries))
        return float(self.timeout_s * (self.retries + 1) + backoff)

    def readiness(self) -> str | None:
        return self._problem

    async def aclose(self) -> None:
        await self._client.aio.aclose()
        await self._http.aclose()

    async def ground(
        self,
        image: Image,
        question: str,
        outputs: list[SemanticRequest] | None = None,
        mode: str = "ground_and_segment",
    ) -> GroundingResult:
        height, width = check_image(image)
        requests = list(outputs or [])
        prompt = build_prompt(question, requests, mode, self.max_targets)
        payload = extract_json(await self._generate(image, prompt))
        if isinstance(payload, list):  # a bare target list: accept it
            payload = {"targets": payload}
        kind = "region" if mode == "region" else "object"
        targets = (
            [] if mode == "describe" else self._targets(payload.get("targets"), width, height, kind)
        )
        semantic = parse_results(_yx_positions(payload, requests), requests)
        for r in requests:
            if r.type in ("position", "pose") and r.name in semantic:
                semantic[r.name] = _to_pixels(semantic[r.name], width, height)
        return GroundingResult(
            answer=str(payload.get("answer", "")),
            reasoning=str(payload.get("reasoning", "")),
            targets=targets,
            outputs=semantic,
        )

    async def point(self, image: Image, query: str) -> list[GroundedTarget]:
        height, width = check_image(image)
        payload = extract_json(
            await self._generate(image, build_point_prompt(query, self.max_targets))
        )
        if isinstance(payload, dict):
            payload = payload.get("targets", payload.get("points", []))
        return self._targets(payload, width, height, "object")

    async def _generate(self, image: Image, prompt: str) -> str:
        ok, jpeg = cv2.imencode(
            ".jpg",
            cv2.cvtColor(image, cv2.COLOR_RGB2BGR),
            [cv2.IMWRITE_JPEG_QUALITY, self.jpeg_quality],
        )
        if not ok:  # pragma: no cover - OpenCV encodes any uint8 RGB frame
            raise ModelError("could not JPEG-encode the frame")
        contents: list[Any] = [
            types.Part.from_bytes(data=jpeg.tobytes(), mime_type="image/jpeg"),
            prompt,
        ]
        thinking = (
            types.ThinkingConfig(thinking_level=types.ThinkingLevel(self.thinking_level))
            if self.thinking_level is not None
            else types.ThinkingConfig(thinking_budget=self.thinking_budget)
        )
        config = types.GenerateContentConfig(
            temperature=self.temperature,
            response_mime_type="application/json",
            thinking_config=thinking,
        )
        attempt = 0
        while True:
            attempt += 1
            if attempt > 1:  # the first request is charged by the pipeline that called us
                charge_cloud_request(f"Gemini retry {attempt - 1}")
            started = time.perf_counter()
            try:
                async with asyncio.timeout(self.timeout_s):
                    response = await self._client.aio.models.generate_content(
                        model=self.model, contents=contents, config=config
                    )
                text = response.text or ""
                self._problem = None
                log.debug(
                    "gemini_answer",
                    model=self.model,
                    attempt=attempt,
                    chars=len(text),
                    duration_ms=round(1000 * (time.perf_counter() - started), 1),
                )
                return text
            except genai_errors.APIError as exc:
                code = int(getattr(exc, "code", 0) or 0)
                if code in (401, 403) or "API_KEY_INVALID" in str(exc):
                    self._problem = f"Gemini refused the API key (HTTP {code})"
                    raise ModelUnavailableError(self._problem, "auth") from exc
                if code not in _RETRYABLE or attempt > self.retries:
                    raise ModelError(
                        f"Gemini call failed (HTTP {code}): {exc.message or exc}",
                        _http_failure(code),
                    ) from exc
                reason = f"http_{code}"
            except _TRANSPORT_ERRORS as exc:
                timed_out = isinstance(exc, TimeoutError) or "Timeout" in type(exc).__name__
                if attempt > self.retries:
                    if timed_out:
                        raise ModelError(
                            f"Gemini call timed out after {self.timeout_s} s", "timeout"
                        ) from exc
                    raise ModelError(f"Gemini unreachable: {exc}", "network") from exc
                reason = "timeout" if timed_out else "transport"
            delay = self.retry_backoff_s * 2 ** (attempt - 1)
            log.warning(
                "gemini_retry", model=self.model, attempt=attempt, reason=reason, delay_s=delay
            )
            await asyncio.sleep(delay)

    @staticmethod
    def _targets(raw: Any, width: int, height: int, kind: str) -> list[GroundedTarget]:
        if raw is None:
            return []
        if not isinstance(raw, list):
            raise BadModelAnswerError(f"targets must be a list, got {type(raw).__name__}")
        targets = []
        for item in raw:
            if not isinstance(item, dict):
                log.error("gemini_target_invalid", item=repr(item)[:80])
                continue
            try:
                box = _box_to_pixels(item.get("box_2d"), width, height)
                point = _point_to_pixels(item.get("point"), width, height)
            except (TypeError, ValueError) as exc:
                log.error("gemini_target_invalid", item=repr(item)[:80], error=str(exc))
                continue
            if box is None and point is None:
                continue
            confidence = item.get("confidence")
            targets.append(
                GroundedTarget(
                    label=str(item.get("label", "")),
                    box=box,
                    points=[point] if point is not None else [],
                    kind="region" if kind == "region" else "object",
                    confidence=float(confidence) if isinstance(confidence, int | float) else None,
                )
            )
        return targets


def _http_failure(code: int) -> FailureKind:
    """The failure kind of an HTTP status Gemini answered (after the retries)."""
    if code == 429:
        return "quota"  # RESOURCE_EXHAUSTED: rate or quota
    if code == 408:
        return "timeout"
    if code >= 500:
        return "server_error"
    return "error"


def _scale(value: Any, size: int) -> int:
    v = float(value)
    if not -1.0 <= v <= 1001.0:
        raise ValueError(f"coordinate {value!r} is not normalized to 0-1000")
    return max(0, min(size, round(v / 1000.0 * size)))


def _point_to_pixels(raw: Any, width: int, height: int) -> tuple[int, int] | None:
    if raw is None:
        return None
    if not isinstance(raw, list | tuple) or len(raw) != 2:
        raise ValueError(f"point must be [y, x], got {raw!r}")
    y, x = raw
    return min(width - 1, _scale(x, width)), min(height - 1, _scale(y, height))


def _box_to_pixels(raw: Any, width: int, height: int) -> tuple[int, int, int, int] | None:
    if raw is None:
        return None
    if not isinstance(raw, list | tuple) or len(raw) != 4:
        raise ValueError(f"box_2d must be [ymin, xmin, ymax, xmax], got {raw!r}")
    y0, x0, y1, x1 = raw
    px0, px1 = sorted((_scale(x0, width), _scale(x1, width)))
    py0, py1 = sorted((_scale(y0, height), _scale(y1, height)))
    if px1 <= px0 or py1 <= py0:
        raise ValueError(f"box_2d {raw!r} has no area")
    return px0, py0, px1, py1


def _yx_positions(payload: Any, requests: list[SemanticRequest]) -> Any:
    """Gemini ER writes image positions as ``[y, x]`` (pose ``[y, x, yaw]``): such a list (or
    a string of one) becomes ``{"y", "x"(, "yaw")}`` before the generic coercion, which would
    read a bare list as x first."""
    if not isinstance(payload, dict) or not isinstance(payload.get("results"), list):
        return payload
    kinds = {r.name: r.type for r in requests if r.type in ("position", "pose")}
    results = []
    for entry in payload["results"]:
        if isinstance(entry, dict) and entry.get("name") in kinds:
            value = entry.get("value")
            if isinstance(value, str):
                found = re.findall(r"-?\d+(?:\.\d+)?", value)
                value = [float(n) for n in found] if value.strip().startswith("[") else value
            if isinstance(value, list) and len(value) in (2, 3):
                named = dict(zip(("y", "x", "yaw"), value, strict=False))
                entry = {**entry, "value": named}
        results.append(entry)
    return {**payload, "results": results}


def _to_pixels(value: dict[str, float], width: int, height: int) -> dict[str, float]:
    """A 0–1000 normalized position/pose → image pixels (x, y only)."""
    return {**value, "x": value["x"] / 1000.0 * width, "y": value["y"] / 1000.0 * height}
