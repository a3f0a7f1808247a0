#!/usr/bin/env bash
# Run every test suite: each package with its own coverage gate (>= 80 %), then the interface
# package's cross-process tests and the cross-package end-to-end tests. All ROS traffic stays on
# loopback with a per-run domain id (set by the shared pytest plugin, robot_stack_testing).
set -uo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST
PACKAGES=(${TEST_PACKAGES:-robot_stack_testing robot_mcp_kit robot_skill_schema robot_site_map robot_ros_bridge robot_mcp_perception mcp_skill_control mcp_perception_buffer robot_mcp_memory robot_mcp_navigation robot_mcp_manipulation robot_sim robot_mcp_episodic robot_language robot_voice_chat})
COV_MIN="${COV_MIN:-80}"
failed=()
summary=()

run_suite() {  # name, pytest args...
  local name=$1; shift
  local started=$SECONDS
  echo "=== $name"
  uv run --frozen pytest -p no:cacheprovider "$@"
  local rc=$?
  summary+=("$name: rc=$rc $((SECONDS - started))s")
  ((rc == 0)) || failed+=("$name")
}

# coverage runs pytest (rather than pytest-cov) so that the shared plugin's own import and
# the servers tests start as child processes are measured too.
run_package() {
  local package=$1 started=$SECONDS
  local data="build/coverage/$package"
  mkdir -p build/coverage && rm -f "$data" "$data".*
  echo "=== $package"
  COVERAGE_FILE="$data" uv run --frozen coverage run --source="$package" \
    -m pytest -p no:cacheprovider "packages/$package" -q
  local rc=$?
  COVERAGE_FILE="$data" uv run --frozen coverage combine -q --keep 2>/dev/null
  COVERAGE_FILE="$data" uv run --frozen coverage report --skip-covered --fail-under="$COV_MIN" \
    | tail -n 15
  local cov_rc=${PIPESTATUS[0]}
  ((rc == 0 && cov_rc != 0)) && echo "$package: coverage below ${COV_MIN}%" && rc=2
  summary+=("$package: rc=$rc $((SECONDS - started))s")
  ((rc == 0)) || failed+=("$package")
}

for package in "${PACKAGES[@]}"; do
  run_package "$package"
done
run_suite interfaces interfaces -q
# cross-package tests in one process (e.g. the episodic question set through the rules chat)
run_suite integration tests/integration -q
# deploy: colcon build of the ROS packages, install.sh in a throwaway root, systemd-analyze
# verify of the units, smoke.sh against a local stack on free ports.
run_suite deploy tests/deploy -q

# The operator UI: generated event types match the brain's models, typecheck, eslint, vitest,
# and a production build into the brain's static directory (served by the e2e tests below).
run_frontend() {
  local started=$SECONDS rc=0
  echo "=== frontend"
  bash scripts/build-frontend.sh || rc=$?
  if ((rc == 0)); then
    (cd frontend && node scripts/gen-events.mjs --check && npm run --silent typecheck \
      && npm run --silent lint && npx vitest run --reporter=dot && npm run --silent build) || rc=$?
  fi
  summary+=("frontend: rc=$rc $((SECONDS - started))s")
  ((rc == 0)) || failed+=("frontend")
}
run_frontend
if compgen -G "tests/e2e/test_*.py" >/dev/null; then
  run_suite e2e tests/e2e -q
fi

printf '%s\n' "--- suites" "${summary[@]}"
if ((${#failed[@]})); then
  echo "FAILED suites: ${failed[*]}"
  exit 1
fi
echo "all suites passed"
