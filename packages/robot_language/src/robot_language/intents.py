"""Intents as data: example sentences per intent (``intents.yaml`` + site files that extend it)."""

from __future__ import annotations

from pathlib import Path
from typing import Literal

from pydantic import BaseModel, ConfigDict, Field

from robot_language.config_file import CONFIG, PhrasingsError, read_model

DEFAULT_INTENTS = CONFIG / "intents.yaml"
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


def load_intents(extra: list[Path] | None = None) -> IntentFile:
    """The shipped intents, extended by ``extra`` files in order: a new intent is added, an
    existing one gets the extra examples and verbs (its kind and tool can't change)."""
    merged = read_model(DEFAULT_INTENTS, IntentFile, "intents")
    for path in extra or []:
        site = read_model(path, IntentFile, "intents")
        for name, intent in site.intents.items():
            known = merged.intents.get(name)
            if known is None:
                merged.intents[name] = intent
                continue
            if intent.kind != known.kind:
                raise PhrasingsError(f"{path}: intent {name!r} is {known.kind}, not {intent.kind}")
            known.examples += [e for e in intent.examples if e not in known.examples]
            known.verbs += [v for v in intent.verbs if v not in known.verbs]
        merged.objects += [o for o in site.objects if o not in merged.objects]
        for word, looks in site.place_words.items():
            merged.place_words[word] = [*merged.place_words.get(word, []), *looks]
    return merged
