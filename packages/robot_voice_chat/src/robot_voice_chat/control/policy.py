"""The tool policy: per ``server.tool`` allow | confirm | deny, plus argument bounds.

Loaded from a versioned YAML file in the brain's config (version + sha256 digest logged and in
readyz). A tool the file does not name gets its decision from its MCP annotations: read-only →
allow; a destructive one → confirm; other annotated tools → allow; **no annotations → deny**
(nothing unknown runs unasked). A motion server is not trusted to describe itself: its unlisted
tools are confirmed (denied without annotations) whatever ``readOnlyHint`` says (issue 27).
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

Action = Literal["allow", "confirm", "deny"]
POLICY_DENIED = "POLICY_DENIED"
OUT_OF_BOUNDS = "OUT_OF_BOUNDS"


class PolicyError(ValueError):
    """The policy file cannot be used (missing, not YAML, wrong shape)."""


class Bound(BaseModel):
    """One argument's bound: a closed set of values, or a numeric range (inclusive)."""

    model_config = ConfigDict(extra="forbid")

    one_of: list[str | int | float] | None = None
    min: float | None = None
    max: float | None = None

    @model_validator(mode="after")
    def _something(self) -> Bound:
        if self.one_of is None and self.min is None and self.max is None:
            raise ValueError("a bound needs one_of, min or max")
        return self

    def violation(self, value: Any) -> str | None:
        """None when ``value`` is inside; else the bound as a sentence for the planner."""
        if self.one_of is not None:
            return None if value in self.one_of else f"one of {self.one_of}"
        if isinstance(value, bool) or not isinstance(value, int | float) or math.isnan(value):
            return f"a number in [{self.min}, {self.max}]"
        if (self.min is not None and value < self.min) or (
            self.max is not None and value > self.max
        ):
            return f"a number in [{self.min}, {self.max}]"
        return None


class ToolRule(BaseModel):
    model_config = ConfigDict(extra="forbid")

    decision: Action | None = None  # None: from the annotations
    bounds: dict[str, Bound] = Field(default_factory=dict)
    reason: str = ""  # shown on the approval card / in the refusal


class PolicyFile(BaseModel):
    model_config = ConfigDict(extra="forbid")

    version: int = Field(ge=1)
    tools: dict[str, ToolRule | Action] = Field(default_factory=dict)

    def rules(self) -> dict[str, ToolRule]:
        return {
            name: rule if isinstance(rule, ToolRule) else ToolRule(decision=rule)
            for name, rule in self.tools.items()
        }


@dataclass(frozen=True)
class Decision:
    action: Action
    code: str | None = None  # POLICY_DENIED / OUT_OF_BOUNDS when refused
    detail: str = ""
    source: Literal["policy", "annotations", "default"] = "policy"
    bound: str | None = None


def default_action(annotations: dict[str, Any] | None, motion_server: bool) -> tuple[Action, str]:
    if annotations is None:
        return "deny", "it is unknown to the policy and its server gives no annotations"
    if motion_server:  # before readOnlyHint: a motion server's word does not loosen anything
        return "confirm", "it belongs to a motion server and the policy does not name it"
    if annotations.get("readOnlyHint") is True:
        return "allow", "read-only (annotations)"
    if annotations.get("destructiveHint", True):  # MCP default: destructive
        return "confirm", "its server marks it destructive"
    return "allow", "not destructive (annotations)"


class ToolPolicy:
    def __init__(self, document: PolicyFile, digest: str, path: str = "") -> None:
        self.version = document.version
        self.digest = digest
        self.path = path
        self._rules = document.rules()

    @classmethod
    def load(cls, path: Path) -> ToolPolicy:
        try:
            raw = path.read_bytes()
        except OSError as exc:
            raise PolicyError(f"policy file {path}: {exc.strerror}") from exc
        try:
            document = PolicyFile.model_validate(yaml.safe_load(raw))
        except (yaml.YAMLError, ValidationError) as exc:
            lines = " ".join(str(exc).split())
            raise PolicyError(f"policy file {path} is invalid: {lines}") from exc
        return cls(document, hashlib.sha256(raw).hexdigest(), str(path))

    def rule(self, tool: str) -> ToolRule | None:
        return self._rules.get(tool)

    def named_tools(self) -> set[str]:
        return set(self._rules)

    def defaults_only(self) -> ToolPolicy:
        """The same version with no entries: what the annotations alone decide."""
        return ToolPolicy(PolicyFile(version=self.version), self.digest, self.path)

    def decide(
        self,
        tool: str,
        arguments: dict[str, Any],
        annotations: dict[str, Any] | None,
        motion_server: bool,
    ) -> Decision:
        rule = self._rules.get(tool)
        if rule is not None and rule.decision is not None:
            action, why, source = rule.decision, rule.reason, "policy"
        else:
            action, why = default_action(annotations, motion_server)
            source = "annotations" if annotations is not None else "default"
        if action == "deny":
            detail = f"{tool} is not allowed by the operator's policy" + (f": {why}" if why else "")
            return Decision("deny", POLICY_DENIED, detail, source)  # type: ignore[arg-type]
        for name, bound in (rule.bounds if rule is not None else {}).items():
            if name not in arguments:
                continue
            allowed = bound.violation(arguments[name])
            if allowed is not None:
                detail = (
                    f"{tool}: {name}={arguments[name]!r} is outside the operator's policy; "
                    f"allowed: {allowed}"
                )
                return Decision("deny", OUT_OF_BOUNDS, detail, "policy", f"{name}: {allowed}")
        return Decision(action, None, why, source)  # type: ignore[arg-type]

    def summary(self) -> dict[str, Any]:
        return {"version": self.version, "digest": self.digest, "path": self.path}
