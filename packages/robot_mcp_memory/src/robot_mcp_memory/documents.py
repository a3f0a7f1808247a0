"""Process documents (spec 002 §8): parse and validate markdown with YAML frontmatter.

A process document is what teaching distils from a mission trace and what the brain reads back
at the start of a similar mission. :data:`FORMAT_SPEC` is the format, verbatim, for prompts.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Any

import yaml

MAX_MARKDOWN_CHARS = 64_000
MAX_ID_CHARS = 80
MAX_TITLE_CHARS = 200
MAX_TASK_PATTERN_CHARS = 500
MAX_TAGS = 20
MAX_TAG_CHARS = 40

SLUG_RE = re.compile(r"^[a-z0-9]+(?:-[a-z0-9]+)*$")

# Canonical (normalised) section names, in the order the format lists them.
SECTION_STEPS = "steps"
SECTION_PITFALLS = "pitfalls and fixes"
SECTION_OPERATOR_NOTES = "operator notes"
REQUIRED_SECTIONS: dict[str, str] = {
    SECTION_STEPS: "## Steps",
    SECTION_PITFALLS: "## Pitfalls & fixes",
    SECTION_OPERATOR_NOTES: "## Operator notes",
}

FORMAT_SPEC = """\
A process document is markdown with YAML frontmatter:

---
id: fetch-package-from-mailroom   # slug: lowercase letters/digits, words joined by single '-'
title: Fetch a package from the mailroom
task_pattern: bring a package or parcel from the mailroom to a person
tags: [mailroom, package, fetch]  # list of short keywords (a comma-separated string works too)
---

## Steps
1. One line per physical action, naming the tools/skills used.

## Pitfalls & fixes
- What went wrong and what fixed it (may be "- none").

## Operator notes
- What the operator said or corrected (may be "- none").

Rules: `id`, `title`, `task_pattern` are required non-empty strings; `## Steps` must not be empty;
all three `##` sections must be present (case-insensitive; "and" may replace "&");
other `##` sections are allowed; at most 64,000 characters."""

_FRONTMATTER_RE = re.compile(r"\A---[ \t]*\n(?P<yaml>.*?)\n?^---[ \t]*$\n?", re.S | re.M)
_HEADING_RE = re.compile(r"^(?P<hashes>#{1,6})[ \t]+(?P<text>.*?)[ \t]*#*[ \t]*$")
_FENCE_RE = re.compile(r"^[ \t]*(```|~~~)")


class DocumentError(ValueError):
    """A process document that cannot be stored; ``problems`` names each thing that is wrong."""

    def __init__(self, problems: list[str]) -> None:
        self.problems = problems
        super().__init__("; ".join(problems))


@dataclass(frozen=True)
class ProcessDocument:
    """A validated process document. ``markdown`` is the document exactly as stored."""

    id: str
    title: str
    task_pattern: str
    tags: tuple[str, ...]
    body: str
    markdown: str
    sections: dict[str, str]


def normalise_section_name(text: str) -> str:
    """``"Pitfalls & Fixes:"`` → ``"pitfalls and fixes"``."""
    text = text.strip().rstrip(":").replace("&", " and ").lower()
    return " ".join(text.split())


def split_sections(body: str) -> dict[str, str]:
    """Level-2 sections of a markdown body, keyed by normalised name (fenced code is skipped).

    A level-1 heading ends the current section; deeper headings belong to the section.
    Raises DocumentError when a level-2 section appears twice.
    """
    sections: dict[str, list[str]] = {}
    current: list[str] | None = None
    in_fence = False
    duplicates: list[str] = []
    for line in body.splitlines():
        if _FENCE_RE.match(line):
            in_fence = not in_fence
        heading = None if in_fence else _HEADING_RE.match(line)
        if heading and len(heading["hashes"]) <= 2:
            if len(heading["hashes"]) == 1:
                current = None
                continue
            name = normalise_section_name(heading["text"])
            if name in sections:
                duplicates.append(f"section '## {heading['text']}' appears more than once")
            current = sections.setdefault(name, [])
            continue
        if current is not None:
            current.append(line)
    if duplicates:
        raise DocumentError(duplicates)
    return {name: "\n".join(lines).strip() for name, lines in sections.items()}


def parse_process(markdown: str) -> ProcessDocument:
    """Parse and validate a process document; raise DocumentError listing every problem."""
    if not isinstance(markdown, str) or not markdown.strip():
        raise DocumentError(["the document is empty; send the whole markdown process document"])
    if len(markdown) > MAX_MARKDOWN_CHARS:
        raise DocumentError(
            [f"the document has {len(markdown)} characters; the limit is {MAX_MARKDOWN_CHARS}"]
        )
    text = markdown.replace("\r\n", "\n").lstrip("\ufeff").strip() + "\n"
    match = _FRONTMATTER_RE.match(text)
    if match is None:
        raise DocumentError(
            [
                "missing YAML frontmatter: the document must start with a line '---', then "
                "id/title/task_pattern/tags, then a closing line '---'"
            ]
        )
    meta = _load_frontmatter(match["yaml"])
    body = text[match.end() :]
    problems = _check_frontmatter(meta)
    sections: dict[str, str] = {}
    try:
        sections = split_sections(body)
    except DocumentError as exc:
        problems.extend(exc.problems)
    else:
        problems.extend(_check_sections(sections))
    if problems:
        raise DocumentError(problems)
    return ProcessDocument(
        id=str(meta["id"]).strip(),
        title=" ".join(str(meta["title"]).split()),
        task_pattern=" ".join(str(meta["task_pattern"]).split()),
        tags=_tags(meta.get("tags")),
        body=body.strip(),
        markdown=text,
        sections=sections,
    )


def _load_frontmatter(raw: str) -> dict[str, Any]:
    try:
        meta = yaml.safe_load(raw)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" at frontmatter line {mark.line + 1}" if mark is not None else ""
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        raise DocumentError([f"the frontmatter is not valid YAML{where}: {problem}"]) from exc
    if not isinstance(meta, dict):
        raise DocumentError(
            ["the frontmatter must be a YAML mapping with keys id, title, task_pattern, tags"]
        )
    return {str(key): value for key, value in meta.items()}


def _check_frontmatter(meta: dict[str, Any]) -> list[str]:
    problems: list[str] = []
    limits = {"id": MAX_ID_CHARS, "title": MAX_TITLE_CHARS, "task_pattern": MAX_TASK_PATTERN_CHARS}
    for key, limit in limits.items():
        value = meta.get(key)
        if value is None or (isinstance(value, str) and not value.strip()):
            problems.append(f"frontmatter field '{key}' is missing or empty")
        elif not isinstance(value, str | int | float) or isinstance(value, bool):
            problems.append(f"frontmatter field '{key}' must be a string")
        elif len(str(value).strip()) > limit:
            problems.append(f"frontmatter field '{key}' is longer than {limit} characters")
    process_id = meta.get("id")
    slug = str(process_id).strip() if isinstance(process_id, str | int) else ""
    if slug and not SLUG_RE.match(slug):
        problems.append(
            f"frontmatter field 'id' ({slug[:MAX_ID_CHARS]!r}) must be a slug: "
            "lowercase letters and digits, words joined by single '-' "
            "(e.g. 'fetch-package-from-mailroom')"
        )
    problems.extend(_check_tags(meta.get("tags")))
    return problems


def _check_tags(raw: Any) -> list[str]:
    if raw is None:
        return []
    if isinstance(raw, str):
        raw = [part for part in raw.split(",") if part.strip()]
    if not isinstance(raw, list):
        return ["frontmatter field 'tags' must be a list of strings, e.g. [mailroom, package]"]
    problems: list[str] = []
    if len(raw) > MAX_TAGS:
        problems.append(f"frontmatter field 'tags' has {len(raw)} entries; the limit is {MAX_TAGS}")
    for tag in raw:
        if not isinstance(tag, str | int | float) or isinstance(tag, bool) or not str(tag).strip():
            problems.append(f"tag {tag!r} must be a non-empty string")
        elif len(str(tag).strip()) > MAX_TAG_CHARS:
            problems.append(f"tag {str(tag)[:MAX_TAG_CHARS]!r}… is longer than {MAX_TAG_CHARS}")
    return problems


def _tags(raw: Any) -> tuple[str, ...]:
    if raw is None:
        return ()
    items = raw.split(",") if isinstance(raw, str) else raw
    seen: dict[str, None] = {}
    for tag in items:
        normalised = " ".join(str(tag).lower().split())
        if normalised:
            seen.setdefault(normalised, None)
    return tuple(seen)


def _check_sections(sections: dict[str, str]) -> list[str]:
    problems = [
        f"missing section '{heading}'"
        for name, heading in REQUIRED_SECTIONS.items()
        if name not in sections
    ]
    if SECTION_STEPS in sections and not sections[SECTION_STEPS]:
        problems.append("section '## Steps' is empty; list at least one step")
    return problems


def render_process(
    process_id: str,
    title: str,
    task_pattern: str,
    tags: list[str] | tuple[str, ...],
    steps: list[str] | tuple[str, ...],
    pitfalls: list[str] | tuple[str, ...] = (),
    operator_notes: list[str] | tuple[str, ...] = (),
) -> str:
    """A process document in the format of :data:`FORMAT_SPEC` (what teaching should produce)."""
    frontmatter = yaml.safe_dump(
        {"id": process_id, "title": title, "task_pattern": task_pattern, "tags": list(tags)},
        sort_keys=False,
        allow_unicode=True,
        width=1000,
    )
    step_lines = "\n".join(f"{index}. {step}" for index, step in enumerate(steps, start=1))
    pitfall_lines = "\n".join(f"- {item}" for item in pitfalls) or "- none"
    note_lines = "\n".join(f"- {item}" for item in operator_notes) or "- none"
    return (
        f"---\n{frontmatter}---\n\n## Steps\n{step_lines}\n\n"
        f"## Pitfalls & fixes\n{pitfall_lines}\n\n## Operator notes\n{note_lines}\n"
    )
