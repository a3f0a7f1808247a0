"""One prompt for grounding + semantic outputs, and a tolerant parser of the JSON answer.

The model is asked for one JSON object::

    {"answer": "...", "reasoning": "...",
     "targets": [{"label": "...", "point": [y, x], "box_2d": [ymin, xmin, ymax, xmax],
                  "confidence": 0.9}],
     "results": [{"name": "<output name>", "value": <typed value>}]}

(coordinates normalized to 0–1000, the Gemini Robotics-ER convention). Parsing is robust to
code fences, prose around the JSON and truncated JSON; each semantic value is coerced to its
declared type (text | number | boolean | list | position | pose). A value that cannot be
coerced is logged (``semantic_output_invalid``) and left out; an answer with no usable JSON
at all raises :class:`BadModelAnswerError` (a :class:`ModelError`: the node keeps the stale
result, it never crashes).
"""

from __future__ import annotations

import json
import re
from collections.abc import Iterable, Sequence
from typing import Any

import structlog

from robot_mcp_perception.models.base import ModelError, SemanticRequest
from robot_mcp_perception.skills import SkillOutput

log = structlog.get_logger(__name__)

OUTPUT_TYPES = ("text", "number", "boolean", "list", "position", "pose")

_TYPE_HELP = {
    "text": "a short string",
    "number": "a JSON number",
    "boolean": "true or false",
    "list": "a JSON array of short strings",
    "position": 'an image position {"y": int, "x": int}, normalized 0-1000',
    "pose": 'an image pose {"y": int, "x": int, "yaw": degrees}, position normalized 0-1000',
}

_MODE_TASK = {
    "ground_and_segment": (
        "Locate the object(s) the request refers to. For each one give its label, one point "
        "on the object and its tight bounding box. If it is not visible, return no targets."
    ),
    "segment_all": (
        "Locate every distinct object the request refers to, one target per instance, each "
        "with its label, one point on the object and its tight bounding box."
    ),
    "region": (
        "Find the free, flat, empty area the request asks for (a place, not an object). "
        'Return it as one target labelled "free space" whose box is that empty rectangle '
        "and whose point is its centre."
    ),
    "describe": "Answer the request about the image. Return no targets.",
}


class BadModelAnswerError(ModelError):
    """The model's answer holds no usable JSON (the result stays stale)."""

    def __init__(self, message: str = "") -> None:
        super().__init__(message, "bad_answer")


def semantic_requests(outputs: Iterable[SkillOutput]) -> list[SemanticRequest]:
    return [SemanticRequest(o.name, o.type, o.description) for o in outputs]


def build_prompt(
    question: str,
    outputs: Sequence[SemanticRequest] = (),
    mode: str = "ground_and_segment",
    max_targets: int = 10,
) -> str:
    """The single prompt for one grounding question and its semantic outputs."""
    if mode not in _MODE_TASK:
        raise ValueError(f"unknown mode {mode!r}; expected one of {sorted(_MODE_TASK)}")
    for o in outputs:
        if o.type not in OUTPUT_TYPES:
            raise ValueError(f"output {o.name!r} has unknown type {o.type!r}")
    lines = [
        "You are the perception module of a robot looking at one camera image.",
        f"Request: {question.strip() or 'describe the scene'}",
        _MODE_TASK[mode],
        f"Return at most {max_targets} targets. Points are [y, x] and boxes are "
        "box_2d [ymin, xmin, ymax, xmax], integers normalized to 0-1000.",
    ]
    if outputs:
        lines.append('Also answer these outputs in "results", one entry per output:')
        lines += [
            f'- "{o.name}" ({o.type}: {_TYPE_HELP[o.type]}): {o.description or o.name}'
            for o in outputs
        ]
    lines.append(
        "Reply with JSON only, exactly this shape: "
        '{"answer": "one sentence", "reasoning": "one sentence", "targets": [{"label": '
        '"...", "point": [y, x], "box_2d": [ymin, xmin, ymax, xmax], "confidence": 0.9}], '
        '"results": [{"name": "...", "value": ...}]}'
    )
    return "\n".join(lines)


def build_point_prompt(query: str, max_points: int = 20) -> str:
    """Prompt for pointing at every instance of ``query`` (used per tile by segment_all)."""
    return (
        f"Point to every instance of: {query.strip() or 'every distinct object'}. "
        f"At most {max_points} items, one per instance. Reply with JSON only: a list "
        '[{"point": [y, x], "box_2d": [ymin, xmin, ymax, xmax], "label": "...", '
        '"confidence": 0.9}], coordinates integers normalized to 0-1000. '
        "Reply [] if there is none."
    )


_FENCE = re.compile(r"```(?:json|JSON)?\s*(.*?)(?:```|$)", re.DOTALL)


def extract_json(text: str) -> Any:
    """The JSON value in a model answer: plain, fenced, surrounded by prose, or truncated."""
    if not text or not text.strip():
        raise BadModelAnswerError("empty model answer")
    candidates = [m.group(1) for m in _FENCE.finditer(text)] + [text]
    for candidate in candidates:
        for start in (i for i, ch in enumerate(candidate) if ch in "{["):
            value = _decode_prefix(candidate[start:])
            if value is not None:
                return value[0]
    raise BadModelAnswerError(f"no JSON in model answer: {text[:120]!r}")


def _decode_prefix(text: str) -> tuple[Any] | None:
    try:
        value, _ = json.JSONDecoder().raw_decode(text)
        return (value,)
    except ValueError:
        pass
    return _repair_truncated(text)


def _repair_truncated(text: str) -> tuple[Any] | None:
    """Close a truncated JSON document at the last complete value."""
    stack: list[str] = []
    in_string = escaped = False
    cut_points: list[tuple[int, str]] = []
    for i, ch in enumerate(text):
        if in_string:
            if escaped:
                escaped = False
            elif ch == "\\":
                escaped = True
            elif ch == '"':
                in_string = False
            continue
        if ch == '"':
            in_string = True
        elif ch in "{[":
            stack.append("}" if ch == "{" else "]")
        elif ch in "}]":
            if not stack:
                return None
            stack.pop()
            if not stack:
                return None  # complete document that raw_decode rejected: malformed
            cut_points.append((i + 1, "".join(reversed(stack))))
        elif ch == "," and stack:
            cut_points.append((i, "".join(reversed(stack))))
    for end, closers in reversed(cut_points[-200:]):
        try:
            return (json.loads(text[:end] + closers),)
        except ValueError:
            continue
    return None


def coerce_value(value: Any, type_: str) -> Any:
    """``value`` as the declared output type; ValueError when it cannot be."""
    if type_ == "text":
        if isinstance(value, str):
            return value.strip()
        if value is None:
            raise ValueError("null text")
        return json.dumps(value) if isinstance(value, dict | list) else str(value)
    if type_ == "number":
        return _number(value)
    if type_ == "boolean":
        return _boolean(value)
    if type_ == "list":
        if isinstance(value, list):
            return [v.strip() if isinstance(v, str) else v for v in value]
        if isinstance(value, str):
            parts = re.split(r",|;|\band\b", value)
            return [p.strip() for p in parts if p.strip()]
        if value is None:
            return []
        return [value]
    if type_ == "position":
        x, y, z, _ = _xyz(value, allow_yaw=False)
        return {"x": x, "y": y} if z is None else {"x": x, "y": y, "z": z}
    if type_ == "pose":
        x, y, z, yaw = _xyz(value, allow_yaw=True)
        return {"x": x, "y": y, "z": z or 0.0, "yaw": yaw or 0.0}
    raise ValueError(f"unknown output type {type_!r}")


def _number(value: Any) -> float | int:
    if isinstance(value, bool):
        raise ValueError("a boolean is not a number")
    if isinstance(value, int | float):
        return value
    if isinstance(value, str):
        m = re.search(r"-?\d+(?:\.\d+)?(?:[eE]-?\d+)?", value)
        if m:
            num = float(m.group(0))
            return int(num) if num.is_integer() and "." not in m.group(0) else num
    raise ValueError(f"not a number: {value!r}")


_TRUE = {"true", "yes", "y", "1", "visible", "present", "found"}
_FALSE = {"false", "no", "n", "0", "none", "absent", "not found", "not visible"}


def _boolean(value: Any) -> bool:
    if isinstance(value, bool):
        return value
    if isinstance(value, int | float) and value in (0, 1):
        return bool(value)
    if isinstance(value, str):
        word = value.strip().strip(".!").lower()
        if word in _TRUE:
            return True
        if word in _FALSE:
            return False
    raise ValueError(f"not a boolean: {value!r}")


def _xyz(value: Any, allow_yaw: bool) -> tuple[float, float, float | None, float | None]:
    if isinstance(value, str):
        nums = [float(n) for n in re.findall(r"-?\d+(?:\.\d+)?", value)]
        value = nums
    if isinstance(value, dict):
        lower = {str(k).lower(): v for k, v in value.items()}
        if "position" in lower and isinstance(lower["position"], dict):
            lower = {**lower, **{str(k).lower(): v for k, v in lower["position"].items()}}
        if "x" not in lower or "y" not in lower:
            raise ValueError(f"position needs x and y: {value!r}")
        x, y = float(_number(lower["x"])), float(_number(lower["y"]))
        z = float(_number(lower["z"])) if lower.get("z") is not None else None
        yaw_raw = next(
            (lower[k] for k in ("yaw", "theta", "angle") if lower.get(k) is not None), None
        )
        yaw = float(_number(yaw_raw)) if yaw_raw is not None else None
        return x, y, z, yaw
    if isinstance(value, list | tuple) and all(
        isinstance(v, int | float) and not isinstance(v, bool) for v in value
    ):
        nums = [float(v) for v in value]
        if len(nums) == 2:
            return nums[0], nums[1], None, None
        if len(nums) == 3:
            return (nums[0], nums[1], None, nums[2]) if allow_yaw else (*nums, None)  # type: ignore[return-value]
        if len(nums) == 4 and allow_yaw:
            return nums[0], nums[1], nums[2], nums[3]
    raise ValueError(f"not a {'pose' if allow_yaw else 'position'}: {value!r}")


def parse_results(payload: Any, outputs: Sequence[SemanticRequest]) -> dict[str, Any]:
    """The declared outputs found in ``payload`` ({"results": [{"name", "value"}]}), coerced.

    Unknown names are ignored; values that cannot be coerced are logged and left out.
    """
    if isinstance(payload, dict):
        entries = payload.get("results", [])
    elif isinstance(payload, list):
        entries = payload
    else:
        entries = []
    declared = {o.name: o for o in outputs}
    parsed: dict[str, Any] = {}
    if isinstance(entries, dict):  # {"results": {"name": value}} — accept it too
        entries = [{"name": k, "value": v} for k, v in entries.items()]
    for entry in entries if isinstance(entries, list) else []:
        if not isinstance(entry, dict) or entry.get("name") not in declared:
            continue
        request = declared[entry["name"]]
        try:
            parsed[request.name] = coerce_value(entry.get("value"), request.type)
        except ValueError as exc:
            log.error(
                "semantic_output_invalid", output=request.name, type=request.type, error=str(exc)
            )
    return parsed


def coerce_outputs(values: dict[str, Any], outputs: Sequence[SemanticRequest]) -> dict[str, Any]:
    """Keep only the declared outputs of ``values``, coerced to their types (bad ones logged)."""
    return parse_results({"results": [{"name": k, "value": v} for k, v in values.items()]}, outputs)
