"""Test support shipped with the package (like ``robot_ros_bridge.testing``): a receiver of
signed events (``receiver``) and a small real NavigateToPose server (``nav2_server``, run as
``python -m robot_mcp_navigation.testing.nav2_server``). Production code never imports it."""
