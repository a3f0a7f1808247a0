"""How a published result relates to fresh data: the markers of ARCHITECTURE §4.1 / §6a.

Nothing re-used or skipped passes as fresh:

- a result segmented on a re-used grounding (the scene was unchanged behind the gate, or a
  prewarm cache hit) carries ``grounding_reused: true`` and ``grounding_stamp`` (ns of the
  frame the grounding was made on) in every detection's ``extra``; its semantic outputs keep
  that grounding frame's stamp;
- a result republished because its run was skipped (gate, rate, budget) or failed keeps its
  original stamp and carries ``stale: true`` + ``stale_reason`` (and, until every reader has
  moved to ``stale_reason``, the same value as ``reason``).

The same markers go, per result, into ``VisionDetectionArray.extra`` (JSON) so that a result
with no detections (describe, ambient_scene) still says it is stale and why, plus
``checked_stamp``: ns of the newest frame the node looked at when it republished.

Who answered (additive, issue 30): ``grounder`` (+ ``grounder_fallback`` and
``fallback_reason`` behind a grounder chain, :mod:`.models.answers`) in every detection's
``extra`` and in the result's. A run that failed before the skill ever had a result publishes
an empty result saying the node **cannot see** — ``cannot_see: true`` + ``cannot_see_reason``
(the failure: ``network``, ``server_error``, ``quota``, ``timeout``, ``budget``, ``auth``,
``bad_answer``, ``error``) — so a reader never takes "the model could not look" for
"nothing there".
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any


@dataclass(frozen=True)
class Provenance:
    stale_reason: str | None = None
    """Why a result is republished instead of recomputed (None: a fresh result)."""
    checked_stamp_ns: int | None = None
    """Stale republish: the frame whose run was skipped or failed."""
    grounding_stamp_ns: int | None = None
    """The frame the (re-used) grounding was made on; None when grounded on this frame."""
    grounding_frame_id: str = ""
    grounded_by: dict[str, Any] = field(default_factory=dict)
    """Who answered the grounding (``grounder``, ``grounder_fallback``, ``fallback_reason``)."""
    cannot_see: str | None = None
    """The failure that left the skill without any result (an empty "cannot see" result)."""

    @property
    def stale(self) -> bool:
        return self.stale_reason is not None

    def stale_copy(self, reason: str, checked_stamp_ns: int | None) -> Provenance:
        """These markers on a republish of the same result."""
        return Provenance(
            reason,
            checked_stamp_ns,
            self.grounding_stamp_ns,
            self.grounding_frame_id,
            self.grounded_by,
        )

    def detection_marks(self) -> dict[str, Any]:
        """Keys merged into every detection's ``extra``."""
        marks: dict[str, Any] = dict(self.grounded_by)
        if self.grounding_stamp_ns is not None:
            marks["grounding_reused"] = True
            marks["grounding_stamp"] = self.grounding_stamp_ns
        if self.stale_reason is not None:
            marks["stale"] = True
            marks["stale_reason"] = self.stale_reason
            marks["reason"] = self.stale_reason
        return marks

    def result_extra(self) -> dict[str, Any]:
        """The JSON object of ``VisionDetectionArray.extra``."""
        extra: dict[str, Any] = {"stale": self.stale}
        if self.stale_reason is not None:
            extra["stale_reason"] = self.stale_reason
            if self.checked_stamp_ns is not None:
                extra["checked_stamp"] = self.checked_stamp_ns
        if self.grounding_stamp_ns is not None:
            extra["grounding_reused"] = True
            extra["grounding_stamp"] = self.grounding_stamp_ns
        extra.update(self.grounded_by)
        if self.cannot_see is not None:
            extra["cannot_see"] = True
            extra["cannot_see_reason"] = self.cannot_see
        return extra


FRESH = Provenance()
