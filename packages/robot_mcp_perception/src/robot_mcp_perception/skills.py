"""Skill = the unit of configuration of the vision node (spec 000 §3, ARCHITECTURE §4.1).

A skill arrives as JSON on ``~/create_vision_task``. :func:`Skill.from_json` validates it
completely and raises :class:`SkillError` (a stable ``code`` + a human ``detail``) for every
problem, so the service can answer ``{"error", "detail"}`` and keep serving. The field set of
the dataclasses is the contract the pipelines rely on.

This module imports neither rclpy nor the models: the MCP bridges use it to validate skills.
"""

from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass, field
from typing import Any, Literal, get_args

SkillMode = Literal["describe", "ground_and_segment", "segment_all", "region"]
OutputType = Literal["text", "number", "boolean", "list", "position", "pose"]

SKILL_MODES: tuple[str, ...] = get_args(SkillMode)
OUTPUT_TYPES: tuple[str, ...] = get_args(OutputType)
GROUNDING_REQUIRED_MODES = frozenset({"ground_and_segment", "region"})
SEGMENTING_MODES = frozenset({"ground_and_segment", "segment_all"})
RESERVED_OUTPUT_NAMES = frozenset({"detections", "detections_meta", "overlay"})

MAX_SKILL_JSON_BYTES = 16_384
MAX_TEXT_CHARS = 2_000
MAX_OUTPUTS = 16
MAX_RATE_HZ = 30.0
_TOKEN = re.compile(r"^[A-Za-z][A-Za-z0-9_]{0,62}$")
"""A ROS topic token: a letter, then letters, digits or underscores (no ``/``, no spaces)."""

_SKILL_KEYS = frozenset(
    {
        "name",
        "description",
        "mode",
        "grounding",
        "segment",
        "outputs",
        "rate_hz",
        "once",
        "watch",
        "prewarm",
    }
)
_OUTPUT_KEYS = frozenset({"name", "type", "description"})
_WATCH_KEYS = frozenset({"output", "equals"})


class SkillError(ValueError):
    """A skill (or a service request) was rejected; ``code`` is stable, ``detail`` is for humans."""

    def __init__(self, code: str, detail: str) -> None:
        super().__init__(f"{code}: {detail}")
        self.code = code
        self.detail = detail

    def to_json(self) -> str:
        return json.dumps({"error": self.code, "detail": self.detail})


@dataclass(frozen=True)
class SkillOutput:
    name: str
    type: OutputType
    description: str = ""

    def to_dict(self) -> dict[str, Any]:
        return {"name": self.name, "type": self.type, "description": self.description}


@dataclass(frozen=True)
class WatchSpec:
    output: str
    equals: object = True

    def to_dict(self) -> dict[str, Any]:
        return {"output": self.output, "equals": self.equals}


@dataclass(frozen=True)
class Skill:
    name: str
    mode: SkillMode
    description: str = ""
    grounding: str = ""
    segment: bool = False
    outputs: tuple[SkillOutput, ...] = field(default_factory=tuple)
    rate_hz: float | None = None
    """None = the node's processing_frequency."""
    once: bool = False
    watch: WatchSpec | None = None
    prewarm: bool = False

    @property
    def segments(self) -> bool:
        """Whether a run of this skill calls the segmenter."""
        return self.segment and self.mode in SEGMENTING_MODES

    def to_dict(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "description": self.description,
            "mode": self.mode,
            "grounding": self.grounding,
            "segment": self.segment,
            "outputs": [output.to_dict() for output in self.outputs],
            "rate_hz": self.rate_hz,
            "once": self.once,
            "watch": self.watch.to_dict() if self.watch else None,
            "prewarm": self.prewarm,
        }

    def to_json(self) -> str:
        return json.dumps(self.to_dict())

    @classmethod
    def from_json(cls, text: str | bytes) -> Skill:
        """Parse and validate one skill; raises :class:`SkillError`."""
        return cls.from_dict(parse_json_object(text, "skill"))

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> Skill:
        """Validate a decoded skill object; raises :class:`SkillError`."""
        _reject_unknown(data, _SKILL_KEYS, "skill")
        name = _token(data, "name", "skill name")
        mode = _require_str(data, "mode")
        if mode not in SKILL_MODES:
            raise SkillError(
                "invalid_mode", f"mode {mode!r} is not one of {', '.join(SKILL_MODES)}."
            )
        grounding = _optional_str(data, "grounding")
        if mode in GROUNDING_REQUIRED_MODES and not grounding.strip():
            raise SkillError("missing_grounding", f"mode {mode!r} needs a non-empty 'grounding'.")
        outputs = _outputs(data.get("outputs", []))
        watch = _watch(data.get("watch"), outputs)
        return cls(
            name=name,
            mode=mode,  # type: ignore[arg-type]  # checked against SKILL_MODES above
            description=_optional_str(data, "description"),
            grounding=grounding,
            segment=_bool(data, "segment", default=mode in SEGMENTING_MODES),
            outputs=outputs,
            rate_hz=_rate(data.get("rate_hz")),
            once=_bool(data, "once", default=False),
            watch=watch,
            prewarm=_bool(data, "prewarm", default=False),
        )


def parse_json_object(text: str | bytes, what: str) -> dict[str, Any]:
    """Decode a JSON object of bounded size or raise :class:`SkillError`."""
    if len(text) > MAX_SKILL_JSON_BYTES:
        raise SkillError(
            "payload_too_large",
            f"the {what} JSON is {len(text)} bytes; the limit is {MAX_SKILL_JSON_BYTES}.",
        )
    try:
        data = json.loads(text)
    except (json.JSONDecodeError, UnicodeDecodeError) as error:
        raise SkillError("invalid_json", f"the {what} is not valid JSON ({error}).") from error
    if not isinstance(data, dict):
        raise SkillError("invalid_request", f"the {what} must be a JSON object.")
    return data


def is_topic_token(name: str) -> bool:
    return bool(_TOKEN.match(name))


def _reject_unknown(data: dict[str, Any], allowed: frozenset[str], what: str) -> None:
    unknown = sorted(set(data) - allowed)
    if unknown:
        raise SkillError(
            "unknown_field",
            f"{what} has unknown field(s) {', '.join(map(repr, unknown))}; "
            f"allowed: {', '.join(sorted(allowed))}.",
        )


def _require_str(data: dict[str, Any], key: str) -> str:
    if key not in data:
        raise SkillError("missing_field", f"the field {key!r} is required.")
    value = data[key]
    if not isinstance(value, str):
        raise SkillError("invalid_type", f"{key!r} must be a string, got {type(value).__name__}.")
    return value


def _optional_str(data: dict[str, Any], key: str) -> str:
    value = data.get(key)
    if value is None:
        return ""
    if not isinstance(value, str):
        raise SkillError("invalid_type", f"{key!r} must be a string, got {type(value).__name__}.")
    if len(value) > MAX_TEXT_CHARS:
        raise SkillError("invalid_value", f"{key!r} is longer than {MAX_TEXT_CHARS} characters.")
    return value


def _token(data: dict[str, Any], key: str, what: str) -> str:
    value = _require_str(data, key)
    if not is_topic_token(value):
        raise SkillError(
            "invalid_name",
            f"{what} {value!r} must start with a letter and contain only letters, digits and "
            "underscores (max 63), because it becomes a ROS topic name.",
        )
    return value


def _bool(data: dict[str, Any], key: str, default: bool) -> bool:
    value = data.get(key)
    if value is None:
        return default
    if not isinstance(value, bool):
        raise SkillError("invalid_type", f"{key!r} must be true or false.")
    return value


def _rate(value: object) -> float | None:
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise SkillError("invalid_type", "'rate_hz' must be a number.")
    rate = float(value)
    if not math.isfinite(rate) or rate <= 0.0:
        raise SkillError("invalid_rate", f"'rate_hz' must be greater than 0, got {value}.")
    if rate > MAX_RATE_HZ:
        raise SkillError("invalid_rate", f"'rate_hz' must be at most {MAX_RATE_HZ:g}.")
    return rate


def _outputs(value: object) -> tuple[SkillOutput, ...]:
    if value is None:
        return ()
    if not isinstance(value, list):
        raise SkillError("invalid_type", "'outputs' must be a list of {name, type, description}.")
    if len(value) > MAX_OUTPUTS:
        raise SkillError("invalid_value", f"a skill may declare at most {MAX_OUTPUTS} outputs.")
    outputs: list[SkillOutput] = []
    for item in value:
        if not isinstance(item, dict):
            raise SkillError("invalid_type", "every output must be an object {name, type}.")
        _reject_unknown(item, _OUTPUT_KEYS, "output")
        name = _token(item, "name", "output name")
        if name in RESERVED_OUTPUT_NAMES:
            raise SkillError(
                "invalid_name", f"output name {name!r} clashes with a /vision/{{skill}}/ topic."
            )
        if any(existing.name == name for existing in outputs):
            raise SkillError("duplicate_output", f"output {name!r} is declared twice.")
        kind = _require_str(item, "type")
        if kind not in OUTPUT_TYPES:
            raise SkillError(
                "invalid_output_type",
                f"output {name!r} has type {kind!r}; allowed: {', '.join(OUTPUT_TYPES)}.",
            )
        description = _optional_str(item, "description")
        outputs.append(SkillOutput(name, kind, description))  # type: ignore[arg-type]
    return tuple(outputs)


def _watch(value: object, outputs: tuple[SkillOutput, ...]) -> WatchSpec | None:
    if value is None:
        return None
    if not isinstance(value, dict):
        raise SkillError("invalid_type", "'watch' must be an object {output, equals}.")
    _reject_unknown(value, _WATCH_KEYS, "watch")
    output = _require_str(value, "output")
    declared = {o.name: o.type for o in outputs}
    if output not in declared:
        raise SkillError(
            "invalid_watch", f"watch.output {output!r} is not one of the skill's outputs."
        )
    if declared[output] != "boolean":
        raise SkillError(
            "invalid_watch",
            f"watch.output {output!r} is a {declared[output]} output; a watcher watches a "
            "boolean output (its rising edge fires the watch event).",
        )
    equals = value.get("equals", True)
    if not isinstance(equals, bool):
        raise SkillError("invalid_watch", "watch.equals must be true or false (boolean output).")
    return WatchSpec(output=output, equals=equals)
