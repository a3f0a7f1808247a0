#!/usr/bin/env bash
# colcon build of the ROS 2 packages (interfaces/ros2_vision_interfaces,
# interfaces/robot_manipulation_interfaces, robot_mcp_perception)
# against the PyPI ROS 2 wheels of this repo's venv, into a throwaway directory.
# On a robot with system ROS 2 use plain `colcon build` instead (README: "System ROS 2").
# Usage: scripts/colcon-build.sh <output-dir>   (build/, install/, log/ are created there)
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
out="${1:?usage: colcon-build.sh <output-dir>}"
venv="${VIRTUAL_ENV:-$root/.venv}"
mkdir -p "$out"
out="$(cd "$out" && pwd)"

# The wheels are the "underlay": ament_cmake, rosidl generators and rclpy live in the venv.
export AMENT_PREFIX_PATH="$venv" CMAKE_PREFIX_PATH="$venv" PATH="$venv/bin:$PATH"
export COLCON_HOME="$out/.colcon"  # no user-wide colcon config changes the result
cd "$out"
exec "$venv/bin/colcon" --log-base "$out/log" build \
  --base-paths "$root/interfaces/ros2_vision_interfaces" \
    "$root/interfaces/robot_manipulation_interfaces" "$root/packages/robot_mcp_perception" \
  --build-base "$out/build" --install-base "$out/install" \
  --event-handlers console_direct- \
  --cmake-args -DPython3_EXECUTABLE="$venv/bin/python" -DBUILD_TESTING=OFF
