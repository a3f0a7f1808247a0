#!/usr/bin/env bash
# Build every ROS 2 interface package under interfaces/ (ros2_vision_interfaces, nav2_msgs,
# audio_common_msgs, ...) from the PyPI ROS 2 wheels and install it into the uv venv, so every
# package imports <pkg>.msg/.srv/.action with no environment set by hand.
# Idempotent: a package is skipped when its installed build matches its sources (one stamp
# per package in the venv).
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
venv="${VIRTUAL_ENV:-$root/.venv}"
python="$venv/bin/python"

# The Python modules a package must provide once installed: one per interface kind it has.
modules_of() {
  local src="$1" pkg="$2" kind modules=()
  for kind in msg srv action; do
    if compgen -G "$src/$kind/*.$kind" >/dev/null; then modules+=("$pkg.$kind"); fi
  done
  (IFS=,; echo "${modules[*]}")
}

build_one() {
  local src="$1"
  local pkg build stamp digest modules
  pkg="$(basename "$src")"
  build="$root/build/$pkg"
  stamp="$venv/.$pkg.stamp"
  modules="$(modules_of "$src" "$pkg")"
  digest="$(cd "$src" && shopt -s nullglob \
    && cat CMakeLists.txt package.xml ../cmake/*.cmake msg/*.msg srv/*.srv action/*.action \
    | sha256sum | cut -d' ' -f1)"
  if [[ -f "$stamp" && "$(cat "$stamp")" == "$digest" ]] \
     && "$python" -c "import $modules" 2>/dev/null; then
    echo "$pkg: up to date"
    return 0
  fi

  echo "$pkg: building into $venv"
  rm -rf "$build"
  mkdir -p "$build"
  (
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
  )

  # ament_cmake_python writes an egg-info; uv treats that as a foreign distribution and would
  # uninstall the generated package on the next exact `uv sync`. The files stay; the record goes.
  rm -rf "$venv"/lib/python3.*/site-packages/"$pkg"-*.egg-info

  "$python" -c "import $modules"
  echo "$digest" >"$stamp"
  echo "$pkg: installed"
}

for package_xml in "$root"/interfaces/*/package.xml; do
  build_one "$(dirname "$package_xml")"
done
