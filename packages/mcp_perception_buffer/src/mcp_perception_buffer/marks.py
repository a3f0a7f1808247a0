"""What the vision node says about how fresh a result is (ARCHITECTURE §4.1, §6a), read back.

A result republished instead of recomputed keeps its original stamp and carries
``stale: true`` + ``stale_reason`` — per result in ``VisionDetectionArray.extra`` and in every
detection's ``extra`` (older nodes: ``reason``). A result segmented on a re-used grounding
carries ``grounding_reused`` + ``grounding_stamp`` (ns).

One reason is not staleness: ``scene_unchanged`` (the gate saw the same scene, so the node
republished its last description). While such republishes keep arriving the scene is
**warm, unchanged since** the original stamp; when they stop (the node stopped producing),
the result goes stale like any other.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

SCENE_UNCHANGED = "scene_unchanged"
SILENT = "no_recent_result"
"""Our own reason: nothing was published (fresh or republished) for ``stale_after_s``."""


@dataclass(frozen=True)
class Marks:
    stale_reason: str | None = None
    checked_at: float | None = None
    """Unix s of the newest frame the node looked at when it republished (None: unknown)."""
    grounding_stamp: float | None = None
    """Unix s of the frame a re-used grounding was made on (None: grounded on this frame)."""


def _seconds(ns: Any) -> float | None:
    if isinstance(ns, int | float) and not isinstance(ns, bool) and ns > 0:
        return float(ns) / 1e9
    return None


def detection_reason(extra: dict[str, Any]) -> str | None:
    if not extra.get("stale"):
        return None
    reason = extra.get("stale_reason") or extra.get("reason") or "republished"
    return str(reason)


def marks_of(meta: dict[str, Any], detections: tuple[dict[str, Any], ...]) -> Marks:
    """The result-level markers, else those of its detections."""
    extras = [d["extra"] for d in detections if isinstance(d.get("extra"), dict)]
    reason = detection_reason(meta) or next(
        (r for e in extras if (r := detection_reason(e)) is not None), None
    )
    grounding = _seconds(meta.get("grounding_stamp")) or next(
        (s for e in extras if (s := _seconds(e.get("grounding_stamp"))) is not None), None
    )
    return Marks(reason, _seconds(meta.get("checked_stamp")), grounding)


def judge(
    stamp: float | None,
    marks: Marks,
    received: float | None,
    now: float,
    stale_after_s: float,
) -> dict[str, Any]:
    """``{stamp, age_s, stale}`` plus ``stale_reason`` / ``unchanged_since`` when they apply."""
    if stamp is None:
        return {"stamp": None, "age_s": None, "stale": True, "stale_reason": SILENT}
    view: dict[str, Any] = {"stamp": stamp, "age_s": round(max(now - stamp, 0.0), 3)}
    if marks.stale_reason == SCENE_UNCHANGED:
        checked = marks.checked_at or received or stamp
        if now - checked <= stale_after_s:
            view.update(stale=False, unchanged_since=stamp, checked_age_s=round(now - checked, 3))
            return view
        view.update(stale=True, stale_reason=SILENT)
        return view
    if marks.stale_reason is not None:
        view.update(stale=True, stale_reason=marks.stale_reason)
        return view
    stale = view["age_s"] > stale_after_s
    view["stale"] = stale
    if stale:
        view["stale_reason"] = SILENT
    return view
