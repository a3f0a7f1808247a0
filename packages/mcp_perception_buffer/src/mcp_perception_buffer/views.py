"""The JSON shapes the perception tools return. Every answer carries ``stamp`` (source stamp,
unix s), ``age_s`` and ``stale``; detections carry label, score, kind, box, point and a
``mask_ref`` (ARCHITECTURE.md §4.2) — never pixels.
"""

from __future__ import annotations

import json
from typing import Any

from mcp_perception_buffer.buffer import OutputValue, Result, SkillBuffer

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


def detection_view(skill: str, stamp: float, index: int, det: dict[str, Any]) -> dict[str, Any]:
    extra = det.get("extra") if isinstance(det.get("extra"), dict) else {}
    assert isinstance(extra, dict)
    view: dict[str, Any] = {
        "label": det.get("label", ""),
        "score": det.get("score"),
        "kind": det.get("kind", "object"),
        "box": det.get("box"),
        "point": det.get("point"),
        "stale": bool(extra.get("stale", False)),
        "mask_ref": {
            "topic": MASK_TOPIC.format(skill=skill),
            "stamp": stamp,
            "index": index,
            "url": _mask_url(extra),
        },
    }
    if extra.get("reason"):
        view["reason"] = extra["reason"]
    rest = {k: v for k, v in extra.items() if k not in ("stale", "reason", "mask_ref", *_URL_KEYS)}
    if rest:
        if len(json.dumps(rest, default=str)) <= MAX_EXTRA_CHARS:
            view["extra"] = rest
        else:
            view["extra_truncated"] = True
    return view


def result_view(skill: str, result: Result, now: float, stale_after_s: float) -> dict[str, Any]:
    detections = [
        detection_view(skill, result.stamp, i, det) for i, det in enumerate(result.detections)
    ]
    view = freshness(result.stamp, now, stale_after_s)
    view["stale"] = view["stale"] or any(d["stale"] for d in detections)
    view["detections"] = detections
    return view


def output_view(item: OutputValue, now: float, stale_after_s: float) -> dict[str, Any]:
    return {"value": item.value, **freshness(item.stamp, now, stale_after_s)}


def latest_view(buf: SkillBuffer, now: float, stale_after_s: float) -> dict[str, Any]:
    """The newest result and the newest value of every output of one skill."""
    view: dict[str, Any] = {"skill": buf.skill}
    view.update(freshness(buf.last_stamp(), now, stale_after_s))
    if buf.results:
        latest = result_view(buf.skill, buf.results[-1], now, stale_after_s)
        view["detections"] = latest["detections"]
        view["detections_stamp"] = latest["stamp"]
        view["stale"] = view["stale"] or latest["stale"]
    else:
        view["detections"] = []
        view["detections_stamp"] = None
    view["outputs"] = {
        name: output_view(values[-1], now, stale_after_s)
        for name, values in sorted(buf.outputs.items())
        if values
    }
    return view


def history_view(
    buf: SkillBuffer, seconds: float, now: float, stale_after_s: float
) -> dict[str, Any]:
    horizon = now - seconds
    results = [
        result_view(buf.skill, r, now, stale_after_s) for r in buf.results if r.stamp >= horizon
    ]
    outputs = {
        name: [output_view(v, now, stale_after_s) for v in values if v.stamp >= horizon]
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
        for names, slot in ((SCENE_TEXT_OUTPUTS, "description"), (SCENE_LIST_OUTPUTS, "objects")):
            for name in names:
                values = buf.outputs.get(name)
                if not values:
                    continue
                candidate = {"skill": buf.skill, **output_view(values[-1], now, stale_after_s)}
                current = description if slot == "description" else objects
                if current is None or candidate["stamp"] > current["stamp"]:
                    if slot == "description":
                        description = candidate
                    else:
                        objects = candidate
        if buf.results:
            latest = result_view(buf.skill, buf.results[-1], now, stale_after_s)
            skills.append({"skill": buf.skill, **latest})
    stamps = [s["stamp"] for s in skills]
    stamps += [v["stamp"] for v in (description, objects) if v is not None]
    view = freshness(max(stamps) if stamps else None, now, stale_after_s)
    if not stamps:
        mode, hint = "cold", COLD_HINT
    elif view["stale"]:
        mode, hint = "stale", STALE_HINT.format(stale_after_s=stale_after_s)
    else:
        mode, hint = "warm", "Fresh results are buffered; no model call was needed."
    view.update(
        mode=mode,
        scene_description=description,
        scene_objects=objects,
        skills=sorted(skills, key=lambda s: s["stamp"], reverse=True),
        hint=hint,
    )
    return view
