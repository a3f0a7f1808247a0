"""Decide what `npm audit --json` reports mean for `make audit` (the npm half of the audit).

    python scripts/npm_audit_gate.py LABEL=ALL.json:RUNTIME.json [LABEL=...]

For each npm project (the operator UI in frontend/, the MCP Inspector in tools/) two reports
of the same lock file: every dependency, and the runtime ones alone (``--omit=dev``). What
fails the gate:

- a vulnerability of severity moderate or above in a runtime dependency (it ships: the UI's
  bundle runs in the operator's browser);
- a high or critical one in any dependency, the build tools included (they run on the machine
  that builds what ships);
- low ones, and moderate ones in build tools only, are listed and do not fail.

Exit 0 passed, 1 vulnerable, 3 npm could not look (e.g. the registry's advisory endpoint
refused the request: then nothing was audited, which is not a pass), 2 no report.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

SEVERITY = {"info": 0, "low": 1, "moderate": 2, "high": 3, "critical": 4}
RUNTIME_FAILS, ANY_FAILS = SEVERITY["moderate"], SEVERITY["high"]


def _read(path: Path) -> tuple[dict[str, Any] | None, str]:
    try:
        report = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        return None, f"no readable npm audit report at {path}: {exc}"
    if not isinstance(report, dict):
        return None, f"{path} is not an npm audit JSON object"
    return report, ""


def _vulnerabilities(report: dict[str, Any]) -> dict[str, dict[str, Any]]:
    found = report.get("vulnerabilities")
    return (
        {k: v for k, v in found.items() if isinstance(v, dict)} if isinstance(found, dict) else {}
    )


def _level(entry: dict[str, Any]) -> int:
    return SEVERITY.get(str(entry.get("severity", "")).lower(), SEVERITY["critical"])


def _line(label: str, name: str, entry: dict[str, Any], runtime: bool) -> str:
    fix = entry.get("fixAvailable")
    fixed = "a fix is available" if fix else "no fix yet"
    where = "runtime" if runtime else "build tool"
    return f"npm audit {label}: {name} ({where}): {entry.get('severity')}, {fixed}"


def decide(label: str, every: dict[str, Any], runtime: dict[str, Any]) -> tuple[int, list[str]]:
    """(exit code, lines) for one project's two reports (already parsed)."""
    for report in (every, runtime):
        if report.get("auditReportVersion") != 2:
            why = report.get("message") or report.get("error") or "not an npm audit v2 report"
            return 3, [
                f"npm audit {label}: FAILED — npm could not audit the lock file, so this is "
                f"not an audit ({str(why)[:200]}); is the registry's advisory endpoint "
                "reachable from here?"
            ]
    shipped = _vulnerabilities(runtime)
    lines, failing = [], 0
    for name, entry in sorted(_vulnerabilities(every).items()):
        in_runtime = name in shipped
        fails = _level(entry) >= (RUNTIME_FAILS if in_runtime else ANY_FAILS)
        failing += fails
        lines.append(_line(label, name, entry, in_runtime) + ("" if fails else " (listed only)"))
    total = (every.get("metadata") or {}).get("dependencies", {}).get("total", "?")
    if failing:
        lines.append(f"npm audit {label}: FAILED — {failing} vulnerable dependencies of {total}")
        return 1, lines
    lines.append(f"npm audit {label}: passed — nothing that fails the gate ({total} dependencies)")
    return 0, lines


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("projects", nargs="+", help="LABEL=ALL.json:RUNTIME.json")
    args = parser.parse_args(argv)
    codes = []
    for project in args.projects:
        label, _, paths = project.partition("=")
        every_path, _, runtime_path = paths.partition(":")
        every, why = _read(Path(every_path))
        runtime, why_runtime = _read(Path(runtime_path)) if runtime_path else (None, "")
        if every is None or runtime is None:
            print(
                f"npm audit {label}: FAILED — {why or why_runtime or 'give ALL.json:RUNTIME.json'}"
            )
            codes.append(2)
            continue
        code, lines = decide(label, every, runtime)
        print("\n".join(lines))
        codes.append(code)
    for worst in (2, 3, 1):
        if worst in codes:
            return worst
    return 0


if __name__ == "__main__":
    sys.exit(main())
