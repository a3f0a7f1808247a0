"""Benchmark (issue 37): the size of the house — Python lines per package (src and tests)
at two commits, the largest modules, and repeated runs between the two motion servers.

Lines are read from git's objects (``git ls-tree`` / ``git cat-file``), so any two commits
compare without checking them out. Repeated runs come from the ``duplicates`` tool when it is
on PATH (it reads the working tree, so only for the current tree); without it that figure is
left out and said so. Writes benchmarks/results/house_size.json.

    uv run python benchmarks/house_size.py [--base 3a0552a] [--head HEAD]
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
from collections import defaultdict
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
RESULTS = Path(__file__).parent / "results" / "house_size.json"
MOTION_SERVERS = ("robot_mcp_navigation", "robot_mcp_manipulation")


def git(*args: str) -> str:
    return subprocess.run(
        ["git", *args], cwd=ROOT, check=True, capture_output=True, text=True
    ).stdout


def python_files(rev: str) -> dict[str, str]:
    """path → blob id of every tracked ``.py`` under packages/ at ``rev``."""
    files = {}
    for line in git("ls-tree", "-r", rev, "--", "packages").splitlines():
        meta, path = line.split("\t", 1)
        if path.endswith(".py"):
            files[path] = meta.split()[2]
    return files


def line_counts(blobs: dict[str, str]) -> dict[str, int]:
    """path → lines, one ``git cat-file --batch`` for all blobs."""
    paths = list(blobs)
    request = "".join(f"{blobs[p]}\n" for p in paths).encode()
    out = subprocess.run(
        ["git", "cat-file", "--batch"], cwd=ROOT, input=request, capture_output=True, check=True
    ).stdout
    counts, offset = {}, 0
    for path in paths:
        header_end = out.index(b"\n", offset)
        size = int(out[offset:header_end].split()[2])
        body = out[header_end + 1 : header_end + 1 + size]
        counts[path] = body.count(b"\n")
        offset = header_end + 1 + size + 1
    return counts


def sizes(rev: str) -> dict[str, Any]:
    counts = line_counts(python_files(rev))
    per: dict[str, dict[str, int]] = defaultdict(lambda: {"src": 0, "tests": 0})
    for path, lines in counts.items():
        parts = path.split("/")
        kind = "src" if parts[2] == "src" else "tests" if parts[2] == "tests" else None
        if kind is not None:
            per[parts[1]][kind] += lines
    largest = sorted(
        ((lines, path) for path, lines in counts.items() if "/src/" in path), reverse=True
    )[:10]
    return {
        "commit": git("rev-parse", "--short", rev).strip(),
        "packages": dict(sorted(per.items())),
        "src_total": sum(p["src"] for p in per.values()),
        "largest_modules": [{"path": p, "lines": n} for n, p in largest],
        "modules_over_500": sum(1 for p, n in counts.items() if "/src/" in p and n > 500),
    }


def motion_server_pairs() -> dict[str, Any] | None:
    """Pairs of ≥ 6 repeated lines with one side in each motion server (current tree)."""
    tool = shutil.which("duplicates")
    if tool is None:
        return None
    out = subprocess.run(
        [tool, "--repo", str(ROOT / "packages"), "--min-lines", "6", "--most", "200",
         "--seconds", "120"],
        capture_output=True, text=True, check=False,
    ).stdout  # fmt: skip
    rows = [
        line for line in out.splitlines()
        if all(server in line for server in MOTION_SERVERS)
    ]  # fmt: skip
    return {"pairs": len(rows), "rows": rows}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--base", default="3a0552a", help="the commit to compare with")
    parser.add_argument("--head", default="HEAD")
    args = parser.parse_args()
    base, head = sizes(args.base), sizes(args.head)
    pairs = motion_server_pairs()
    result = {"base": base, "head": head, "motion_server_pairs_now": pairs}
    RESULTS.parent.mkdir(parents=True, exist_ok=True)
    RESULTS.write_text(json.dumps(result, indent=2))
    names = sorted(set(base["packages"]) | set(head["packages"]))
    print(f"{'package':28} {'src ' + base['commit']:>14} {'src ' + head['commit']:>14}")
    for name in names:
        before = base["packages"].get(name, {}).get("src", 0)
        after = head["packages"].get(name, {}).get("src", 0)
        print(f"{name:28} {before:>14} {after:>14}")
    print(f"{'all src':28} {base['src_total']:>14} {head['src_total']:>14}")
    print(f"modules over 500 lines: {base['modules_over_500']} -> {head['modules_over_500']}")
    if pairs is None:
        print("motion-server pairs: `duplicates` is not on PATH here; not measured")
    else:
        print(f"motion-server pairs (>= 6 lines) now: {pairs['pairs']}")
    print(f"written: {RESULTS}")


if __name__ == "__main__":
    main()
