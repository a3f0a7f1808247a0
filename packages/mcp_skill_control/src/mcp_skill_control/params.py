"""Template params: declared as a bare name (a string param) or ``{name, type}`` with
``type`` in string | number | integer | boolean; values are checked and converted to the
declared type before they are substituted into the skill.

A placeholder that is a whole YAML value (``rate_hz: "{rate}"``) takes the typed value (a
number stays a number); inside longer text it is written as JSON would (``true``, ``2.5``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Literal, get_args

from mcp_skill_control.errors import CatalogError

ParamType = Literal["string", "number", "integer", "boolean"]
PARAM_TYPES: tuple[str, ...] = get_args(ParamType)
MAX_PARAM_CHARS = 500
ParamValue = str | int | float | bool
_SAMPLES: dict[str, ParamValue] = {"string": "x", "number": 1.0, "integer": 1, "boolean": True}


@dataclass(frozen=True)
class ParamSpec:
    name: str
    type: ParamType = "string"

    @property
    def sample(self) -> ParamValue:
        """A valid value, used to check at load time that the template fills."""
        return _SAMPLES[self.type]

    def convert(self, value: Any) -> ParamValue:
        """``value`` as this param's type; raises ``CatalogError(invalid_params)``."""
        converted: ParamValue | None = _CONVERTERS[self.type](value)
        if converted is None:
            raise CatalogError(
                "invalid_params", f"param {self.name!r} must be a {self.type}, got {value!r}"
            )
        if isinstance(converted, str):
            converted = converted.strip()
            if not converted:
                raise CatalogError("invalid_params", f"param {self.name!r} must not be empty")
            if len(converted) > MAX_PARAM_CHARS:
                raise CatalogError(
                    "invalid_params", f"param {self.name!r} is over {MAX_PARAM_CHARS} chars"
                )
        return converted


def parse_param(item: Any, template: str) -> ParamSpec:
    if isinstance(item, str) and item:
        return ParamSpec(item)
    if isinstance(item, dict) and isinstance(item.get("name"), str) and item["name"]:
        kind = item.get("type", "string")
        unknown = sorted(set(item) - {"name", "type"})
        if kind in PARAM_TYPES and not unknown:
            return ParamSpec(item["name"], kind)
    raise CatalogError(
        "catalog_invalid",
        f"template {template!r}: each param is a name or {{name, type}} with type one of "
        f"{', '.join(PARAM_TYPES)}; got {item!r}",
    )


def as_text(value: ParamValue) -> str:
    """How a typed value reads inside a longer string."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float) and value.is_integer():
        return str(int(value)) if abs(value) < 1e15 else repr(value)
    return str(value)


def _string(value: Any) -> str | None:
    if isinstance(value, bool):
        return None
    if isinstance(value, str):
        return value
    if isinstance(value, int | float) and math.isfinite(value):
        return as_text(value)
    return None


def _number(value: Any) -> float | None:
    if isinstance(value, bool):
        return None
    if isinstance(value, str):
        try:
            value = float(value.strip())
        except ValueError:
            return None
    if isinstance(value, int | float) and math.isfinite(value):
        return float(value)
    return None


def _integer(value: Any) -> int | None:
    number = _number(value)
    if number is None or not number.is_integer():
        return None
    return int(number)


def _boolean(value: Any) -> bool | None:
    if isinstance(value, bool):
        return value
    if isinstance(value, str) and value.strip().lower() in ("true", "false"):
        return value.strip().lower() == "true"
    return None


_CONVERTERS: dict[str, Callable[[Any], ParamValue | None]] = {
    "string": _string,
    "number": _number,
    "integer": _integer,
    "boolean": _boolean,
}
