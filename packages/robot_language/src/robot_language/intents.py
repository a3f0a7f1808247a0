"""Intents as data: example sentences per intent (``intents.yaml`` + site files that extend it)."""

from __future__ import annotations

from pathlib import Path
from typing import Literal

import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError

DEFAULT_INTENTS = Path(__file__).parent / "config" / "intents.yaml"
IntentKind = Literal["action", "answer", "stop", "refuse"]


class Intent(BaseModel):
    model_config = ConfigDict(extra="forbid")

    kind: IntentKind
    examples: list[str] = Field(min_length=1)
    verbs: list[str] = Field(default_factory=list)
    tool: str | None = None  # the tool an answer comes from (readiness: absent tool → no answer)


class IntentFile(BaseModel):
    model_config = ConfigDict(extra="forbid")

    intents: dict[str, Intent] = Field(default_factory=dict)
    place_words: dict[str, list[str]] = Field(default_factory=dict)
    # the site's known object labels: a sentence that names one must use it (the check)
    objects: list[str] = Field(default_factory=list)


class IntentsError(ValueError):
    """An intents file is missing or malformed (named, with the reason)."""


def load_intents(extra: list[Path] | None = None) -> IntentFile:
    """The shipped intents, extended by ``extra`` files in order: a new intent is added, an
    existing one gets the extra examples and verbs (its kind and tool can't change)."""
    merged = _read(DEFAULT_INTENTS)
    for path in extra or []:
        site = _read(path)
        for name, intent in site.intents.items():
            known = merged.intents.get(name)
            if known is None:
                merged.intents[name] = intent
                continue
            if intent.kind != known.kind:
                raise IntentsError(f"{path}: intent {name!r} is {known.kind}, not {intent.kind}")
            known.examples += [e for e in intent.examples if e not in known.examples]
            known.verbs += [v for v in intent.verbs if v not in known.verbs]
        merged.objects += [o for o in site.objects if o not in merged.objects]
        for word, looks in site.place_words.items():
            merged.place_words[word] = [*merged.place_words.get(word, []), *looks]
    return merged


def _read(path: Path) -> IntentFile:
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise IntentsError(f"can't read intents file {path}: {exc}") from exc
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f"{path}:{mark.line + 1}" if mark is not None else str(path)
        raise IntentsError(f"bad intents file {where}: {exc}") from exc
    try:
        return IntentFile.model_validate(data or {})
    except ValidationError as exc:
        first = exc.errors()[0]
        field = ".".join(str(part) for part in first["loc"])
        line = _line_of(text, first["loc"])
        raise IntentsError(f"bad intents file {path}:{line}: {field}: {first['msg']}") from exc


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
