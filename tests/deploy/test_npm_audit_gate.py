"""`make audit` audits the npm lock files too (issue 31): the UI's runtime dependencies fail
the gate from moderate up, build tools from high up, and an audit npm could not run (recorded
here: the registry answered 405 to the advisory endpoint) is a failure, never a pass."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[2]
GATE = ROOT / "scripts/npm_audit_gate.py"
REFUSED = Path(__file__).parent / "data/npm-audit-endpoint-refused.json"


def report(**vulnerabilities: str) -> dict[str, Any]:
    """An npm audit v2 report with ``name=severity`` entries."""
    return {
        "auditReportVersion": 2,
        "vulnerabilities": {
            name: {"name": name, "severity": severity, "fixAvailable": True}
            for name, severity in vulnerabilities.items()
        },
        "metadata": {"dependencies": {"total": 400}},
    }


def gate(tmp_path: Path, every: Any, runtime: Any) -> tuple[int, str]:
    paths = []
    for name, data in (("all", every), ("runtime", runtime)):
        path = tmp_path / f"{name}.json"
        path.write_text(data if isinstance(data, str) else json.dumps(data), encoding="utf-8")
        paths.append(path)
    done = subprocess.run(
        [sys.executable, str(GATE), f"frontend={paths[0]}:{paths[1]}"],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    return done.returncode, done.stdout + done.stderr


def test_an_audit_npm_could_not_run_fails_and_says_so(tmp_path: Path) -> None:
    refused = REFUSED.read_text(encoding="utf-8")
    code, output = gate(tmp_path, refused, refused)
    assert code == 3
    assert "not an audit" in output
    assert "405 Method Not Allowed" in output


def test_a_clean_lock_file_passes(tmp_path: Path) -> None:
    code, output = gate(tmp_path, report(), report())
    assert code == 0, output
    assert "passed" in output


def test_a_moderate_vulnerability_in_what_ships_fails(tmp_path: Path) -> None:
    code, output = gate(
        tmp_path,
        report(**{"socket.io-parser": "moderate"}),
        report(**{"socket.io-parser": "moderate"}),
    )
    assert code == 1
    assert "socket.io-parser (runtime): moderate" in output


def test_build_tools_fail_from_high_and_lower_ones_are_listed_only(tmp_path: Path) -> None:
    code, output = gate(tmp_path, report(esbuild="moderate", vite="low"), report())
    assert code == 0, output
    assert "esbuild (build tool): moderate, a fix is available (listed only)" in output
    code, output = gate(tmp_path, report(rollup="high"), report())
    assert code == 1
    assert "rollup (build tool): high" in output


def test_a_missing_report_fails(tmp_path: Path) -> None:
    done = subprocess.run(
        [sys.executable, str(GATE), f"frontend={tmp_path / 'none.json'}:{tmp_path / 'x.json'}"],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert done.returncode == 2


def test_make_audit_runs_npm_audit_on_every_npm_lock_file() -> None:
    makefile = (ROOT / "Makefile").read_text(encoding="utf-8")
    recipe = makefile.split("\naudit:", 1)[1].split("\n\n", 1)[0]
    assert "npm audit --package-lock-only --json" in recipe
    assert "--omit=dev" in recipe
    assert "scripts/npm_audit_gate.py" in recipe
    projects = makefile.split("NPM_PROJECTS :=", 1)[1].split("\n", 1)[0].split()
    found = [*ROOT.glob("*/package-lock.json"), *ROOT.glob("tools/*/package-lock.json")]
    locks = {str(p.parent.relative_to(ROOT)) for p in found}
    assert set(projects) == locks
