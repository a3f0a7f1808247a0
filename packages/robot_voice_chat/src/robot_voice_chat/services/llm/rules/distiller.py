"""Template distiller: a mission transcript (teaching.render_transcript) → a process document
in the robot-mcp-memory format (spec 002 §8) without a model: the capability calls that
worked become the steps, each failure and the calls that followed it a pitfall, the user's
words the operator notes."""

from __future__ import annotations

import re

TRANSCRIPT_HEADER = "Mission transcript:"
_CALL = re.compile(r"^CALL (?P<tool>[\w.\-]+)\((?P<args>.*)\) -> (?P<status>ok|ERROR)")
# Local mission tools are bookkeeping, not process steps.
_BOOKKEEPING = {
    "set_plan", "update_plan", "mark_step", "say", "register_reaction",
    "wait_for_events", "ask_user", "finish_mission",
}  # fmt: skip
_QUERIES = {"navigation.get_task", "navigation.list_locations", "navigation.get_pose"}
_WORD = re.compile(r"[a-z0-9]+")
_STOP = {"the", "a", "an", "to", "from", "and", "in", "of", "me", "please", "for", "with", "my"}


def _slug(text: str, limit: int = 60) -> str:
    words = _WORD.findall(text.lower())
    slug = "-".join(words)[:limit].strip("-")
    return slug or "process"


def distill(transcript: str) -> str:
    lines = transcript.removeprefix(TRANSCRIPT_HEADER).strip().splitlines()
    instruction = next(
        (ln.split(":", 1)[1].strip() for ln in lines if ln.startswith("INSTRUCTION:")), ""
    )
    instruction = " ".join(instruction.split()) or "a mission"
    steps: list[str] = []
    pitfalls: list[str] = []
    notes: list[str] = []
    failure: str | None = None
    for line in lines:
        call = _CALL.match(line)
        if line.startswith("EVENT ") and " failed " in line:
            failure = line.removeprefix("EVENT ").split("] ", 1)[-1][:200]
        elif line.startswith("USER:"):
            notes.append(line.removeprefix("USER:").strip())
        elif call is not None and call["tool"] not in _BOOKKEEPING | _QUERIES:
            entry = f"{call['tool']}({call['args'][:160]})"
            if call["status"] == "ERROR":
                pitfalls.append(f"{entry} failed → check the arguments and the server")
                continue
            if failure is not None:
                pitfalls.append(f"{failure} → {entry}")
                failure = None
            if not steps or steps[-1] != entry:
                steps.append(entry)
    words = [w for w in _WORD.findall(instruction.lower()) if w not in _STOP and len(w) > 2]
    tags = list(dict.fromkeys(words))[:8] or ["mission"]
    title = instruction[:1].upper() + instruction[1:]
    body = [
        "---",
        f"id: {_slug(instruction)}",
        f"title: {_yaml(title[:200])}",
        f"task_pattern: {_yaml(instruction.lower()[:500])}",
        f"tags: [{', '.join(tags)}]",
        "---",
        "## Steps",
        *(f"{i}. {s}" for i, s in enumerate(steps or ["(no capability calls were needed)"], 1)),
        "## Pitfalls & fixes",
        *([f"- {p}" for p in pitfalls] or ["- none seen"]),
        "## Operator notes",
        *([f"- {n}" for n in notes] or ["- none"]),
        "",
    ]
    return "\n".join(body)


def _yaml(text: str) -> str:
    """A YAML scalar that survives colons and quotes."""
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'
