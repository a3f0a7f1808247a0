#!/usr/bin/env bash
# One-shot, idempotent set-up of a fresh Debian/Ubuntu machine (or a developer's laptop):
# system build tools, uv, the locked workspace, the ROS 2 interface package, sample frames.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

need_apt=()
command -v cmake >/dev/null 2>&1 || need_apt+=(cmake)
command -v g++ >/dev/null 2>&1 || need_apt+=(g++)
command -v make >/dev/null 2>&1 || need_apt+=(make)
command -v espeak-ng >/dev/null 2>&1 || need_apt+=(espeak-ng)  # the robot preset's speech output
# deploy checks: `systemd-analyze verify` on the units (tests/deploy), curl + jq for smoke.sh
command -v systemd-analyze >/dev/null 2>&1 || need_apt+=(systemd)
command -v curl >/dev/null 2>&1 || need_apt+=(curl)
command -v jq >/dev/null 2>&1 || need_apt+=(jq)
command -v caddy >/dev/null 2>&1 || need_apt+=(caddy)  # deploy/Caddyfile, tests/deploy
# the SROS2 policy under deploy/sros2: validated against sros2's schemas (tests/deploy)
command -v xmllint >/dev/null 2>&1 || need_apt+=(libxml2-utils)
command -v xsltproc >/dev/null 2>&1 || need_apt+=(xsltproc)
# robot-sim's camera renders with MuJoCo off-screen on the CPU through OSMesa (MUJOCO_GL=osmesa)
compgen -G '/usr/lib/*/libOSMesa.so*' >/dev/null || need_apt+=(libosmesa6)
# the memory tests start a throwaway PostgreSQL server (robot_stack_testing.postgres)
compgen -G '/usr/lib/postgresql/*/bin/pg_ctl' >/dev/null || need_apt+=(postgresql)
if ((${#need_apt[@]})); then
  echo "setup: installing ${need_apt[*]} with apt-get"
  sudo_cmd=()
  [[ $(id -u) -ne 0 ]] && sudo_cmd=(sudo)
  "${sudo_cmd[@]}" apt-get update -qq
  DEBIAN_FRONTEND=noninteractive "${sudo_cmd[@]}" apt-get install -y -qq "${need_apt[@]}"
fi

if ! command -v uv >/dev/null 2>&1; then
  echo "setup: installing uv with pip"
  python3 -m pip install --quiet --user uv 2>/dev/null || python3 -m pip install --quiet uv
  export PATH="$HOME/.local/bin:$PATH"
fi

# --inexact: the ROS 2 wheels carry inner *.egg-info records that an exact sync would treat
# as foreign distributions and uninstall (std_msgs, rcl_interfaces, ...).
uv sync --all-packages --inexact --frozen --quiet
bash scripts/build-interfaces.sh
# Where PYTHONDONTWRITEBYTECODE is set (this CI machine sets it), no process writes .pyc files,
# so each of the hundreds of processes the tests start would compile every module it imports
# anew (~1-2 s each). Compile once: the locked dependencies when the lock changes, the
# workspace's own sources every time (only changed files are recompiled).
bytecode_stamp=".venv/.bytecode-$(cat uv.lock interfaces/*/package.xml | sha256sum | cut -c1-16)"
if [[ ! -f $bytecode_stamp ]]; then
  site=$(uv run --frozen python -c "import sysconfig; print(sysconfig.get_paths()['purelib'])")
  uv run --frozen python -m compileall -q -j 0 "$site" >/dev/null 2>&1 || true
  rm -f .venv/.bytecode-*
  touch "$bytecode_stamp"
fi
uv run --frozen python -m compileall -q -j 0 packages/*/src >/dev/null
# The model libraries (ultralytics, timm, transformers, torch on the CPU) for the real-library
# tests of the vision node's adapters (issue 30); skips with a note where no local torch index is.
bash scripts/install-model-libs.sh

if uv run --frozen python -c "import robot_mcp_perception.sample_scenes" 2>/dev/null \
   && [[ ! -f data/scenes/.complete ]]; then
  echo "setup: generating sample frames into data/scenes"
  uv run --frozen python -m robot_mcp_perception.sample_scenes data/scenes
  touch data/scenes/.complete
fi
# The MCP Inspector CLI (a third-party MCP client) for the stdio tests: pinned by
# tools/mcp-inspector/package-lock.json, installed once; nothing downloads at test time.
inspector=tools/mcp-inspector
if [[ ! -f $inspector/node_modules/.package-lock.json \
      || $inspector/package-lock.json -nt $inspector/node_modules/.package-lock.json ]]; then
  if command -v npm >/dev/null 2>&1; then
    echo "setup: installing the MCP Inspector CLI (npm ci in $inspector)"
    (cd "$inspector" && npm ci --no-audit --no-fund --loglevel=error)
  else
    echo "setup: npm not found; the stdio tests need it (apt-get install npm)" >&2
  fi
fi
# The operator UI (frontend/) and the browser its end-to-end tests drive (Debian's chromium;
# Playwright launches it by path, never downloads one).
bash scripts/build-frontend.sh
if ! command -v chromium >/dev/null 2>&1 && command -v apt-get >/dev/null 2>&1; then
  echo "setup: installing chromium with apt-get (browser tests of the UI)"
  sudo_cmd=()
  [[ $(id -u) -ne 0 ]] && sudo_cmd=(sudo)
  "${sudo_cmd[@]}" apt-get update -qq
  DEBIAN_FRONTEND=noninteractive "${sudo_cmd[@]}" apt-get install -y -qq chromium
fi
echo "setup: done"
