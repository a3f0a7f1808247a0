#!/usr/bin/env bash
# One-shot, idempotent set-up of a fresh Debian/Ubuntu machine (or a developer's laptop):
# system build tools, uv, the locked workspace, the ROS 2 interface package, sample frames.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

need_apt=()
command -v cmake >/dev/null 2>&1 || need_apt+=(cmake)
command -v g++ >/dev/null 2>&1 || need_apt+=(g++)
command -v make >/dev/null 2>&1 || need_apt+=(make)
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

if uv run --frozen python -c "import robot_mcp_perception.sample_scenes" 2>/dev/null \
   && [[ ! -f data/scenes/.complete ]]; then
  echo "setup: generating sample frames into data/scenes"
  uv run --frozen python -m robot_mcp_perception.sample_scenes data/scenes
  touch data/scenes/.complete
fi
echo "setup: done"
