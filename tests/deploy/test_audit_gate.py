"""`make audit`'s verdict comes from pip-audit's JSON report, not its "No known
vulnerabilities": an audit whose lookups failed is a failure (recorded report from this
network: 249 of 249 dependencies "not found on PyPI")."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[2]
GATE = ROOT / "scripts/audit_gate.py"
RECORDED = Path(__file__).parent / "data/pip-audit-lookups-failed.json"


def gate(tmp_path: Path, report: Any, *args: str) -> tuple[int, str]:
    path = tmp_path / "pip-audit.json"
    path.write_text(report if isinstance(report, str) else json.dumps(report), encoding="utf-8")
    done = subprocess.run(
        [sys.executable, str(GATE), str(path), *args],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    return done.returncode, done.stdout + done.stderr


def checked(name: str, version: str = "1.0", vulns: list[Any] | None = None) -> dict[str, Any]:
    return {"name": name, "version": version, "vulns": vulns or []}


def skipped(name: str) -> dict[str, Any]:
    return {
        "name": name,
        "skip_reason": f"Dependency not found on PyPI and could not be audited: {name} (1.0)",
    }


def test_the_recorded_report_whose_lookups_all_failed_fails_with_a_sentence(
    tmp_path: Path,
) -> None:
    code, output = gate(tmp_path, RECORDED.read_text(encoding="utf-8"))
    assert code == 3
    assert "could not check 249 of 249 dependencies" in output
    assert "not an audit" in output
    assert "passed" not in output


def test_a_clean_report_passes_and_names_the_few_it_could_not_check(tmp_path: Path) -> None:
    report = {"dependencies": [checked("httpx"), checked("fastapi"), skipped("local-pkg")]}
    code, output = gate(tmp_path, report)
    assert code == 0, output
    assert "not checked: Dependency not found on PyPI" in output
    assert re.search(r"passed — no known vulnerabilities \(2 of 3 dependencies checked", output)


def test_more_skipped_than_allowed_fails(tmp_path: Path) -> None:
    report = {"dependencies": [checked("httpx"), *(skipped(f"p{i}") for i in range(3))]}
    assert gate(tmp_path, report)[0] == 0
    code, output = gate(tmp_path, report, "--max-skipped", "2")
    assert code == 3
    assert "could not check 3 of 4" in output


def test_known_vulnerabilities_fail_and_are_listed_with_their_fixes(tmp_path: Path) -> None:
    vuln = {"id": "PYSEC-2099-1", "fix_versions": ["2.0.1"], "aliases": [], "description": "x"}
    report = {"dependencies": [checked("jinja2", "2.0", [vuln]), checked("httpx")], "fixes": []}
    code, output = gate(tmp_path, report)
    assert code == 1
    assert "jinja2 2.0: PYSEC-2099-1 (fixed in 2.0.1)" in output
    assert "1 vulnerable dependencies" in output


def test_a_missing_or_foreign_report_fails(tmp_path: Path) -> None:
    assert gate(tmp_path, "not json")[0] == 2
    assert gate(tmp_path, {"results": []})[0] == 2
    assert gate(tmp_path, [1, 2])[0] == 2
    done = subprocess.run(
        [sys.executable, str(GATE), str(tmp_path / "absent.json")],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert done.returncode == 2
    assert "no readable pip-audit report" in done.stdout


def test_make_audit_decides_with_the_gate_not_with_pip_audit_alone() -> None:
    makefile = (ROOT / "Makefile").read_text(encoding="utf-8")
    recipe = makefile.split("\naudit:", 1)[1].split("\n\n", 1)[0]
    assert "--format json" in recipe
    assert "scripts/audit_gate.py" in recipe
