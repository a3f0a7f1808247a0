#!/usr/bin/env bash
# Build ros2_vision_interfaces from the PyPI ROS 2 wheels and install it into the uv venv,
# so every package imports ros2_vision_interfaces.msg/.srv with no environment set by hand.
# Idempotent: skipped when the installed build matches the interface sources.
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
venv="${VIRTUAL_ENV:-$root/.venv}"
src="$root/interfaces/ros2_vision_interfaces"
build="$root/build/ros2_vision_interfaces"
stamp="$venv/.ros2_vision_interfaces.stamp"
python="$venv/bin/python"

digest="$(cd "$src" && cat CMakeLists.txt package.xml cmake/*.cmake msg/*.msg srv/*.srv | sha256sum | cut -d' ' -f1)"
if [[ -f "$stamp" && "$(cat "$stamp")" == "$digest" ]] \
   && "$python" -c "import ros2_vision_interfaces.msg, ros2_vision_interfaces.srv" 2>/dev/null; then
  echo "ros2_vision_interfaces: up to date"
  exit 0
fi

echo "ros2_vision_interfaces: building into $venv"
rm -rf "$build"
mkdir -p "$build"
export AMENT_PREFIX_PATH="$venv" CMAKE_PREFIX_PATH="$venv"
cmake -S "$src" -B "$build" \
  -DCMAKE_INSTALL_PREFIX="$venv" \
  -DPython3_EXECUTABLE="$python" \
  -DBUILD_TESTING=OFF >"$build/configure.log" 2>&1 \
  || { tail -40 "$build/configure.log"; exit 1; }
cmake --build "$build" -j"$(nproc)" >"$build/build.log" 2>&1 \
  || { tail -40 "$build/build.log"; exit 1; }
cmake --install "$build" >"$build/install.log" 2>&1 \
  || { tail -40 "$build/install.log"; exit 1; }

# ament_cmake_python writes an egg-info; uv treats that as a foreign distribution and would
# uninstall the generated package on the next exact `uv sync`. The files stay; the record goes.
rm -rf "$venv"/lib/python3.*/site-packages/ros2_vision_interfaces-*.egg-info

"$python" -c "import ros2_vision_interfaces.msg, ros2_vision_interfaces.srv"
echo "$digest" >"$stamp"
echo "ros2_vision_interfaces: installed"
