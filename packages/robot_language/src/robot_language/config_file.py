"""Phrasings as data: a YAML file under ``config/`` (or a site's) read into a pydantic model;
a broken file is refused with its file and line."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Annotated, TypeVar

import yaml
from pydantic import BaseModel, BeforeValidator, ConfigDict, RootModel, ValidationError

Model = TypeVar("Model", bound=BaseModel)
Value = TypeVar("Value")
CONFIG = Path(__file__).parent / "config"


class Strict(BaseModel):
    """A file's model: no key it does not know, read once and never changed."""

    model_config = ConfigDict(extra="forbid", frozen=True)


def _one_pattern(value: object) -> object:
    return "|".join(map(str, value)) if isinstance(value, list) else value


# a regular expression, written whole or as the list of its alternatives; compiled on load
Regex = Annotated[re.Pattern[str], BeforeValidator(_one_pattern)]


class PhrasingsError(ValueError):
    """A phrasings file is missing or malformed (named, with its line and the reason)."""


def read_model(path: Path, model: type[Model], what: str) -> Model:
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise PhrasingsError(f"can't read {what} file {path}: {exc}") from exc
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f"{path}:{mark.line + 1}" if mark is not None else str(path)
        raise PhrasingsError(f"bad {what} file {where}: {exc}") from exc
    try:
        return model.model_validate(data or {})
    except ValidationError as exc:
        first = exc.errors()[0]
        field = ".".join(str(part) for part in first["loc"])
        line = _line_of(text, first["loc"])
        raise PhrasingsError(f"bad {what} file {path}:{line}: {field}: {first['msg']}") from exc


def _line_of(text: str, loc: tuple[int | str, ...]) -> int:
    """The 1-based line of the YAML node at ``loc`` (or of the deepest part of it that exists)."""
    node = yaml.compose(text)
    for part in loc:
        if isinstance(node, yaml.MappingNode):
            found = [value for key, value in node.value if key.value == part]
        elif isinstance(node, yaml.SequenceNode) and isinstance(part, int):
            found = node.value[part : part + 1]
        else:
            found = []
        if not found:
            break
        node = found[0]
    return node.start_mark.line + 1 if node is not None else 1


def patterns(name: str, *needed: str) -> dict[str, re.Pattern[str]]:
    """``config/<name>.yaml``: named regular expressions, compiled."""
    return _named(name, RootModel[dict[str, Regex]], needed)


def word_lists(name: str, *needed: str) -> dict[str, frozenset[str]]:
    """``config/<name>.yaml``: named lists of words."""
    return _named(name, RootModel[dict[str, frozenset[str]]], needed)


def _named(
    name: str, model: type[RootModel[dict[str, Value]]], needed: tuple[str, ...]
) -> dict[str, Value]:
    """Each of ``needed`` must be there: a broken or short file is refused with its name."""
    path = CONFIG / f"{name}.yaml"
    found = read_model(path, model, name).root
    missing = [n for n in needed if n not in found]
    if missing:
        raise PhrasingsError(f"bad {name} file {path}: no {', '.join(missing)}")
    return found
