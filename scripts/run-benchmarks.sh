#!/usr/bin/env bash
# Run every benchmark script (each prints a summary and writes benchmarks/results/<name>.json).
set -uo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST
mkdir -p benchmarks/results
failed=()
for bench in benchmarks/*.py; do
  [[ $(basename "$bench") == _* ]] && continue
  echo "=== $bench"
  uv run --frozen python "$bench" || failed+=("$bench")
done
if ((${#failed[@]})); then echo "FAILED: ${failed[*]}"; exit 1; fi
