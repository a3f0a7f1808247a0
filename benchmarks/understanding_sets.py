"""Understanding layer (issue 22): understood % and wrong actions on phrasing sets A and B,
before (the exact grammar alone) and after; ms per command p50/p99; model load time; RSS added.

    uv run --frozen python benchmarks/understanding_sets.py
"""

from __future__ import annotations

import json
import statistics
import time
from pathlib import Path

from robot_voice_chat.services.llm.understanding.scoring import (
    OFFICE_LIST_LOCATIONS,
    grammar_reader,
    load_set,
    score,
)

DATA = Path(__file__).parents[1] / "packages/robot_voice_chat/tests/unit/understanding/data"
RESULTS = Path(__file__).parent / "results" / "understanding_sets.json"


def _rss_mb() -> float:
    return int(Path("/proc/self/statm").read_text().split()[1]) * 4096 / 1e6


def main() -> None:
    rss_before = _rss_mb()
    started = time.perf_counter()
    from robot_voice_chat.services.llm.understanding.understand import Understanding

    understanding = Understanding()
    load_s = time.perf_counter() - started
    rss_added = _rss_mb() - rss_before
    places = understanding.places(OFFICE_LIST_LOCATIONS)
    timings: list[float] = []

    def after(text: str) -> list[str]:
        t0 = time.perf_counter()
        codes = understanding.understand(text, places).code()
        timings.append((time.perf_counter() - t0) * 1000)
        return codes

    report: dict[str, object] = {"load_s": round(load_s, 3), "rss_added_mb": round(rss_added, 1)}
    for name in ("set_a", "set_b"):
        items = load_set(DATA / f"{name}.yaml")
        for label, reader in (("before", grammar_reader), ("after", after)):
            result = score(items, reader)
            report[f"{name}_{label}"] = {
                "items": result.total,
                "understood_pct": result.understood_pct,
                "wrong_actions": len(result.wrong),
                "per_intent": result.intent_accuracy(),
                "misses": [m[0] for m in result.misses],
            }
    for _ in range(4):  # steadier percentiles
        for text, _ in load_set(DATA / "set_a.yaml"):
            after(text)
    timings.sort()
    report["ms_p50"] = round(statistics.median(timings), 3)
    report["ms_p99"] = round(timings[int(len(timings) * 0.99) - 1], 3)
    RESULTS.parent.mkdir(exist_ok=True)
    RESULTS.write_text(json.dumps(report, indent=2) + "\n")
    for name in ("set_a", "set_b"):
        for label in ("before", "after"):
            r = report[f"{name}_{label}"]
            assert isinstance(r, dict)
            print(f"{name} {label:6}: {r['understood_pct']:5.1f} % understood of {r['items']}, "
                  f"{r['wrong_actions']} wrong actions")  # fmt: skip
    print(f"ms/command p50 {report['ms_p50']} p99 {report['ms_p99']}; load {report['load_s']} s; "
          f"RSS +{report['rss_added_mb']} MB → {RESULTS}")  # fmt: skip


if __name__ == "__main__":
    main()
