"""The skill template catalog (spec 001 §3): load, list, fill.

A template is a vision-node skill with ``{param}`` placeholders. :meth:`Catalog.fill`
substitutes the params and validates the result with the schema the vision node uses
(:meth:`robot_skill_schema.Skill.from_dict`), so a skill that would be refused by the node is
refused here first, with the same error code.
"""

from __future__ import annotations

import copy
import re
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from mcp_skill_control.errors import CatalogError
from mcp_skill_control.params import ParamSpec, ParamValue, as_text, parse_param
from robot_skill_schema import Skill, SkillError

__all__ = ["Catalog", "CatalogError", "Template", "validate_skill"]

_PLACEHOLDER = re.compile(r"\{([A-Za-z_][A-Za-z0-9_]*)\}")


@dataclass(frozen=True)
class Template:
    name: str
    description: str
    params: tuple[ParamSpec, ...]
    skill: Mapping[str, Any]
    watch: Mapping[str, Any] | None = None

    @property
    def is_watcher(self) -> bool:
        return self.watch is not None

    def summary(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "description": self.description,
            "params": [p.name for p in self.params],
            "param_types": {p.name: p.type for p in self.params},
            "watcher": self.is_watcher,
            "mode": self.skill.get("mode"),
        }


class Catalog:
    """An immutable set of templates, keyed by name."""

    def __init__(self, templates: list[Template]) -> None:
        self._templates = {t.name: t for t in templates}
        if len(self._templates) != len(templates):
            raise CatalogError("duplicate_template", "two templates share a name")
        for template in templates:  # every template must fill into a valid skill
            self.fill(template.name, {p.name: p.sample for p in template.params})

    @classmethod
    def load(cls, path: str | Path) -> Catalog:
        """Read a ``skills.yaml``; raises :class:`CatalogError` on any malformed template."""
        try:
            data = yaml.safe_load(Path(path).read_text(encoding="utf-8"))
        except (OSError, yaml.YAMLError) as error:
            raise CatalogError("catalog_unreadable", f"cannot read {path}: {error}") from error
        if not isinstance(data, dict) or not isinstance(data.get("templates"), list):
            raise CatalogError("catalog_invalid", f"{path} needs a top-level 'templates' list")
        return cls([_parse_template(item) for item in data["templates"]])

    def list(self) -> list[Template]:
        return list(self._templates.values())

    def get(self, name: str) -> Template:
        template = self._templates.get(name)
        if template is None:
            known = ", ".join(sorted(self._templates))
            raise CatalogError("unknown_template", f"no template {name!r}; known: {known}")
        return template

    def fill(self, template_name: str, params: Mapping[str, Any]) -> dict[str, Any]:
        """The validated skill dict for ``template_name`` with ``params`` substituted.

        The skill is named after the template; the caller may rename it (collisions).
        """
        template = self.get(template_name)
        names = [p.name for p in template.params]
        missing = [name for name in names if name not in params]
        if missing:
            raise CatalogError(
                "missing_params",
                f"template {template.name!r} needs params {names}; missing {missing}",
            )
        unknown = sorted(set(params) - set(names))
        if unknown:
            raise CatalogError(
                "unknown_params",
                f"template {template.name!r} takes params {names}; got unexpected {unknown}",
            )
        values = {p.name: p.convert(params[p.name]) for p in template.params}
        skill = _substitute(copy.deepcopy(dict(template.skill)), values)
        skill["name"] = template.name
        skill.setdefault("description", _fill_text(template.description, values))
        if template.watch is not None:
            skill["watch"] = dict(template.watch)
        return validate_skill(skill)


def validate_skill(skill: Mapping[str, Any]) -> dict[str, Any]:
    """Validate with the vision node's schema; raise :class:`CatalogError` with its code."""
    try:
        Skill.from_dict(dict(skill))
    except SkillError as error:
        raise CatalogError(error.code, error.detail) from error
    return dict(skill)


def _substitute(node: Any, values: Mapping[str, ParamValue]) -> Any:
    if isinstance(node, str):
        whole = _PLACEHOLDER.fullmatch(node)
        if whole is not None:
            return _lookup(whole.group(1), values)
        return _fill_text(node, values)
    if isinstance(node, list):
        return [_substitute(item, values) for item in node]
    if isinstance(node, dict):
        return {key: _substitute(item, values) for key, item in node.items()}
    return node


def _fill_text(text: str, values: Mapping[str, ParamValue]) -> str:
    return _PLACEHOLDER.sub(lambda match: as_text(_lookup(match.group(1), values)), text)


def _lookup(key: str, values: Mapping[str, ParamValue]) -> ParamValue:
    if key not in values:
        raise CatalogError("undeclared_param", f"placeholder {{{key}}} is not a param")
    return values[key]


def _parse_template(item: Any) -> Template:
    if not isinstance(item, dict):
        raise CatalogError("catalog_invalid", "every template must be a mapping")
    name = item.get("name")
    skill = item.get("skill")
    params = item.get("params", [])
    watch = item.get("watch")
    if not isinstance(name, str) or not name:
        raise CatalogError("catalog_invalid", "a template needs a 'name'")
    if not isinstance(skill, dict):
        raise CatalogError("catalog_invalid", f"template {name!r} needs a 'skill' mapping")
    if not isinstance(params, list):
        raise CatalogError("catalog_invalid", f"template {name!r}: 'params' must be a list")
    if watch is not None and not isinstance(watch, dict):
        raise CatalogError("catalog_invalid", f"template {name!r}: 'watch' must be a mapping")
    return Template(
        name=name,
        description=str(item.get("description", "")),
        params=tuple(parse_param(p, name) for p in params),
        skill=skill,
        watch=watch,
    )
