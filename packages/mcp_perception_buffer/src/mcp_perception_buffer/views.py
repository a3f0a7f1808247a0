"""The JSON shapes the perception tools return. Every answer carries ``stamp`` (source stamp,
unix s), ``age_s`` and ``stale`` (with ``stale_reason`` when stale, or ``unchanged_since``
for a scene the node reports unchanged: see :mod:`.marks`); detections carry label, score,
kind, box, point and a ``mask_ref`` (ARCHITECTURE.md §4.2) — never pixels.
"""

from __future__ import annotations

import json
from datetime import UTC, datetime
from typing import Any

from mcp_perception_buffer.buffer import OutputValue, Result, SkillBuffer
from mcp_perception_buffer.marks import Marks, detection_reason, judge, marks_of

MASK_TOPIC = "/vision/{skill}/detections"
MAX_EXTRA_CHARS = 2_000
_URL_KEYS = ("mask_url", "url")
SCENE_TEXT_OUTPUTS = ("scene_description", "description")
SCENE_LIST_OUTPUTS = ("scene_objects", "objects")


def freshness(stamp: float | None, now: float, stale_after_s: float) -> dict[str, Any]:
    if stamp is None:
        return {"stamp": None, "age_s": None, "stale": True}
    age = max(now - stamp, 0.0)
    return {"stamp": stamp, "age_s": round(age, 3), "stale": age > stale_after_s}


def _mask_url(extra: dict[str, Any]) -> str | None:
    for key in _URL_KEYS:
        if isinstance(extra.get(key), str):
            return str(extra[key])
    ref = extra.get("mask_ref")
    if isinstance(ref, dict) and isinstance(ref.get("url"), str):
        return str(ref["url"])
    return None


_MARK_KEYS = ("stale", "stale_reason", "reason", "grounding_reused", "grounding_stamp")


def detection_view(skill: str, stamp: float, index: int, det: dict[str, Any]) -> dict[str, Any]:
    extra = det.get("extra") if isinstance(det.get("extra"), dict) else {}
    assert isinstance(extra, dict)
    reason = detection_reason(extra)
    view: dict[str, Any] = {
        "label": det.get("label", ""),
        "score": det.get("score"),
        "kind": det.get("kind", "object"),
        "box": det.get("box"),
        "point": det.get("point"),
        "stale": reason is not None,
        "mask_ref": {
            "topic": MASK_TOPIC.format(skill=skill),
            "stamp": stamp,
            "index": index,
            "url": _mask_url(extra),
        },
    }
    if reason is not None:
        view["stale_reason"] = reason
    if extra.get("grounding_reused"):
        view["grounding_reused"] = True
        view["grounding_stamp"] = extra.get("grounding_stamp")
    rest = {k: v for k, v in extra.items() if k not in (*_MARK_KEYS, "mask_ref", *_URL_KEYS)}
    if rest:
        if len(json.dumps(rest, default=str)) <= MAX_EXTRA_CHARS:
            view["extra"] = rest
        else:
            view["extra_truncated"] = True
    return view


def result_marks(result: Result) -> Marks:
    return marks_of(result.meta, result.detections)


def result_view(skill: str, result: Result, now: float, stale_after_s: float) -> dict[str, Any]:
    marks = result_marks(result)
    view = judge(result.stamp, marks, result.received, now, stale_after_s)
    view["detections"] = [
        detection_view(skill, result.stamp, i, det) for i, det in enumerate(result.detections)
    ]
    if marks.grounding_stamp is not None:
        view["grounding_reused"] = True
        view["grounding_stamp"] = marks.grounding_stamp
    view.update(answer_marks(result.meta))
    return view


_ANSWER_KEYS = (
    "grounder",
    "grounder_fallback",
    "fallback_reason",
    "cannot_see",
    "cannot_see_reason",
)


def answer_marks(meta: dict[str, Any]) -> dict[str, Any]:
    """Who answered (``grounder``, ``grounder_fallback``, ``fallback_reason``) and whether the
    node could not look at all (``cannot_see`` + ``cannot_see_reason``): never "nothing there"."""
    return {k: meta[k] for k in _ANSWER_KEYS if k in meta}


def output_view(
    item: OutputValue, now: float, stale_after_s: float, result: Result | None = None
) -> dict[str, Any]:
    """An output value; one published with (or before) a marked result shares its marks:
    a semantic output republished stale keeps its original stamp (§6a)."""
    marks = Marks()
    received = None
    if result is not None and item.stamp <= result.stamp + 1e-6:
        marks, received = result_marks(result), result.received
    return {"value": item.value, **judge(item.stamp, marks, received, now, stale_after_s)}


def latest_view(buf: SkillBuffer, now: float, stale_after_s: float) -> dict[str, Any]:
    """The newest result and the newest value of every output of one skill."""
    view: dict[str, Any] = {"skill": buf.skill}
    latest_result = buf.results[-1] if buf.results else None
    outputs = {
        name: output_view(values[-1], now, stale_after_s, latest_result)
        for name, values in sorted(buf.outputs.items())
        if values
    }
    if latest_result is not None:
        latest = result_view(buf.skill, latest_result, now, stale_after_s)
        view.update({k: v for k, v in latest.items() if k != "detections"})
        view["detections"] = latest["detections"]
        view["detections_stamp"] = latest["stamp"]
    else:
        newest = max(outputs.values(), key=lambda o: o["stamp"], default=None)
        view.update(judge(None, Marks(), None, now, stale_after_s))
        if newest is not None:
            view.update({k: v for k, v in newest.items() if k != "value"})
        view["detections"] = []
        view["detections_stamp"] = None
    view["stamp"] = buf.last_stamp()
    view["outputs"] = outputs
    return view


def history_view(
    buf: SkillBuffer, seconds: float, now: float, stale_after_s: float
) -> dict[str, Any]:
    horizon = now - seconds
    results = [
        result_view(buf.skill, r, now, stale_after_s) for r in buf.results if r.stamp >= horizon
    ]
    latest_result = buf.results[-1] if buf.results else None
    outputs = {
        name: [
            output_view(v, now, stale_after_s, latest_result) for v in values if v.stamp >= horizon
        ]
        for name, values in sorted(buf.outputs.items())
    }
    view: dict[str, Any] = {"skill": buf.skill, "seconds": seconds}
    view.update(freshness(buf.last_stamp(), now, stale_after_s))
    view["results"] = results
    view["outputs"] = {name: values for name, values in outputs.items() if values}
    return view


def buffer_summary(
    buf: SkillBuffer, topics: list[str], now: float, stale_after_s: float
) -> dict[str, Any]:
    return {
        "skill": buf.skill,
        "topics": topics,
        "results": len(buf.results),
        "outputs": {name: len(values) for name, values in sorted(buf.outputs.items())},
        **freshness(buf.last_stamp(), now, stale_after_s),
    }


COLD_HINT = (
    "Nothing is warm: no skill has published recently. For a fresh view call "
    "skill_control.instantiate_skill(template='describe_scene', params={}) and then "
    "perception.wait_for_result(skill=<the returned skill_id>) (one model call); to find a "
    "specific object use the find_object template instead. For what was seen earlier, ask "
    "the memory server."
)
STALE_HINT = (
    "What is buffered is stale (older than {stale_after_s:g} s). If you need the current "
    "scene, instantiate describe_scene (or find_object) with skill_control and call "
    "wait_for_result."
)


def scene_view(buffers: list[SkillBuffer], now: float, stale_after_s: float) -> dict[str, Any]:
    """what_do_you_see: the latest scene description + latest detections across skills."""
    description: dict[str, Any] | None = None
    objects: dict[str, Any] | None = None
    skills: list[dict[str, Any]] = []
    for buf in buffers:
        latest_result = buf.results[-1] if buf.results else None
        for names, slot in ((SCENE_TEXT_OUTPUTS, "description"), (SCENE_LIST_OUTPUTS, "objects")):
            for name in names:
                values = buf.outputs.get(name)
                if not values:
                    continue
                candidate = {
                    "skill": buf.skill,
                    **output_view(values[-1], now, stale_after_s, latest_result),
                }
                current = description if slot == "description" else objects
                if current is None or candidate["stamp"] > current["stamp"]:
                    if slot == "description":
                        description = candidate
                    else:
                        objects = candidate
        if latest_result is not None:
            latest = result_view(buf.skill, latest_result, now, stale_after_s)
            skills.append({"skill": buf.skill, **latest})
    parts = [*skills, *(v for v in (description, objects) if v is not None)]
    stamps = [p["stamp"] for p in parts]
    view = freshness(max(stamps) if stamps else None, now, stale_after_s)
    unchanged = [p for p in parts if not p["stale"] and "unchanged_since" in p]
    if not stamps:
        mode, hint = "cold", COLD_HINT
    elif all(p["stale"] for p in parts):
        view["stale"] = True
        mode, hint = "stale", STALE_HINT.format(stale_after_s=stale_after_s)
    else:
        view["stale"] = False
        mode, hint = "warm", "Fresh results are buffered; no model call was needed."
        if unchanged and all(p["stale"] or "unchanged_since" in p for p in parts):
            since = min(p["unchanged_since"] for p in unchanged)
            view["unchanged_since"] = since
            hint = (
                f"warm, unchanged since {_clock_time(since)}: the camera still sees the "
                "scene described; no model call was needed."
            )
    view.update(
        mode=mode,
        scene_description=description,
        scene_objects=objects,
        skills=sorted(skills, key=lambda s: s["stamp"], reverse=True),
        hint=hint,
    )
    return view


def _clock_time(stamp: float) -> str:
    return datetime.fromtimestamp(stamp, tz=UTC).strftime("%H:%M:%S UTC")
