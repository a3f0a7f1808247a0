"""FallbackGrounder: a primary grounder with a fallback behind it (ARCHITECTURE §6c).

Typically Gemini Robotics-ER (cloud) with the on-board open-vocabulary detector behind it. A
call goes to the primary; when the primary fails with an outage (:data:`~.base.OUTAGES`:
``network``, ``server_error`` (5xx), ``quota`` (429), ``timeout``, ``budget`` (the node's cloud
budget refused the request: nothing was sent) or ``auth`` (the key was refused)) the fallback
answers the same call. Other failures (an unusable answer) propagate as before.

Back-off: after an outage (not ``budget``, which is the node's own limit) the primary is left
alone for ``retry_after_s``, doubling on each further outage up to ``max_retry_after_s``; in
that time the fallback answers at once (reason ``backoff``) and no cloud request is made or
counted. The first call after the back-off tries the primary again; its success ends the
outage (``grounder_recovered``).

Metering: the chain charges the primary's cloud request itself, right before sending it (a
refused charge is a ``budget`` failure, answered by the fallback); a local fallback is never
charged. Every answer is noted (:mod:`.answers`) so the published result says who answered.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Awaitable, Callable
from typing import TypeVar

import structlog

from robot_mcp_perception.models.answers import Answer, note
from robot_mcp_perception.models.base import (
    OUTAGES,
    GroundedTarget,
    Grounder,
    GroundingResult,
    Image,
    ModelError,
    SemanticRequest,
)
from robot_mcp_perception.models.metering import charge_cloud_request

log = structlog.get_logger(__name__)
T = TypeVar("T")
BACKOFF = "backoff"


class FallbackGrounder(Grounder):
    composite = True

    def __init__(
        self,
        primary: Grounder,
        fallback: Grounder,
        retry_after_s: float = 10.0,
        max_retry_after_s: float = 300.0,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        if retry_after_s <= 0 or max_retry_after_s < retry_after_s:
            raise ValueError("retry_after_s must be > 0 and <= max_retry_after_s")
        self.primary = primary
        self.fallback = fallback
        self.cost_class = primary.cost_class
        self.name = primary.name
        self.retry_after_s = retry_after_s
        self.max_retry_after_s = max_retry_after_s
        self._clock = clock
        self._lock = threading.Lock()
        self._outages = 0
        self._retry_at = 0.0
        self.last_outage: str | None = None
        """The kind of the primary's last outage while it lasts; None when it answers."""

    @property
    def worst_case_s(self) -> float | None:
        worst = [g.worst_case_s for g in (self.primary, self.fallback)]
        known = [w for w in worst if w is not None]
        return sum(known) if known else None

    def readiness(self) -> str | None:
        # A refused key is survivable with a fallback: the node stays ready, /healthz says why.
        return self.fallback.readiness()

    async def ground(
        self,
        image: Image,
        question: str,
        outputs: list[SemanticRequest] | None = None,
        mode: str = "ground_and_segment",
    ) -> GroundingResult:
        return await self._answer(lambda g: g.ground(image, question, outputs, mode))

    async def point(self, image: Image, query: str) -> list[GroundedTarget]:
        return await self._answer(lambda g: g.point(image, query))

    async def _answer(self, call: Callable[[Grounder], Awaitable[T]]) -> T:
        reason = self._backing_off()
        if reason is None:
            try:
                if self.primary.cost_class == "cloud":
                    charge_cloud_request(f"{self.primary.name or 'primary grounder'} request")
                answer = await call(self.primary)
            except ModelError as exc:
                if exc.kind not in OUTAGES:
                    raise
                reason = exc.kind
                self._on_outage(exc)
            else:
                self._on_success()
                note(Answer(self.primary.name, fallback=False))
                return answer
        fallen_back = await call(self.fallback)
        note(Answer(self.fallback.name, fallback=True, reason=reason))
        return fallen_back

    def _backing_off(self) -> str | None:
        with self._lock:
            return BACKOFF if self._outages and self._clock() < self._retry_at else None

    def _on_outage(self, exc: ModelError) -> None:
        if exc.kind == "budget":  # the node's own limit, not the primary's fault: no back-off
            log.warning("grounder_fallback", reason="budget", fallback=self.fallback.name)
            return
        with self._lock:
            self._outages += 1
            delay = min(self.max_retry_after_s, self.retry_after_s * 2 ** (self._outages - 1))
            self._retry_at = self._clock() + delay
            self.last_outage = exc.kind
        log.warning(
            "grounder_fallback",
            reason=exc.kind,
            primary=self.primary.name,
            fallback=self.fallback.name,
            retry_in_s=delay,
            error=str(exc),
        )

    def _on_success(self) -> None:
        with self._lock:
            recovered = self._outages > 0
            self._outages = 0
            self._retry_at = 0.0
            self.last_outage = None
        if recovered:
            log.info("grounder_recovered", primary=self.primary.name)
