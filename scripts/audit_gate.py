"""Decide what a pip-audit JSON report means: `make audit` passes only when it really looked.

    python scripts/audit_gate.py build/pip-audit.json [--max-skipped N]

pip-audit says "No known vulnerabilities found" even when it could not look packages up
(every lookup failing on a network without PyPI's JSON API: each dependency is then
"skipped" with "not found on PyPI"). This reads the report instead of pip-audit's exit code:

- exit 0: every dependency checked (at most --max-skipped skipped), none vulnerable;
- exit 1: known vulnerabilities (each listed with its fix versions);
- exit 3: more than --max-skipped dependencies could not be checked: the audit did not run;
- exit 2: no report, or not pip-audit's JSON format.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

DEFAULT_MAX_SKIPPED = 5  # a few local/unpublished packages are normal; hundreds are not


def decide(report: dict[str, Any], max_skipped: int) -> tuple[int, list[str]]:
    """(exit code, lines to print) for a parsed pip-audit JSON report."""
    dependencies = report.get("dependencies")
    if not isinstance(dependencies, list):
        return 2, ["audit: the report has no 'dependencies' list (not pip-audit --format json)"]
    skipped = [d for d in dependencies if isinstance(d, dict) and d.get("skip_reason")]
    checked = [d for d in dependencies if isinstance(d, dict) and not d.get("skip_reason")]
    vulnerable = [d for d in checked if d.get("vulns")]
    lines = []
    for dep in vulnerable:
        for vuln in dep["vulns"]:
            fixes = ", ".join(vuln.get("fix_versions") or []) or "no fix yet"
            package = f"{dep.get('name')} {dep.get('version')}"
            lines.append(f"audit: {package}: {vuln.get('id')} (fixed in {fixes})")
    total = len(dependencies)
    summary = f"{len(checked)} of {total} dependencies checked, {len(skipped)} could not be"
    if len(skipped) > max_skipped:
        examples = "; ".join(str(d.get("skip_reason")) for d in skipped[:3])
        lines.append(
            f"audit: FAILED — pip-audit could not check {len(skipped)} of {total} dependencies "
            f"(more than {max_skipped}), so this is not an audit; is PyPI's JSON API "
            f"reachable from here? e.g. {examples}"
        )
        return 3, lines
    if vulnerable:
        lines.append(f"audit: FAILED — {len(vulnerable)} vulnerable dependencies ({summary})")
        return 1, lines
    lines.extend(f"audit: not checked: {d.get('skip_reason')}" for d in skipped)
    lines.append(f"audit: passed — no known vulnerabilities ({summary})")
    return 0, lines


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("report", type=Path)
    parser.add_argument("--max-skipped", type=int, default=DEFAULT_MAX_SKIPPED)
    args = parser.parse_args(argv)
    try:
        report = json.loads(args.report.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        print(f"audit: FAILED — no readable pip-audit report at {args.report}: {exc}")
        return 2
    if not isinstance(report, dict):
        print("audit: FAILED — the report is not a JSON object (not pip-audit --format json)")
        return 2
    code, lines = decide(report, args.max_skipped)
    print("\n".join(lines))
    return code


if __name__ == "__main__":
    sys.exit(main())
