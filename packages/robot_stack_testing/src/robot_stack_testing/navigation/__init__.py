"""Test doubles around ``robot_mcp_navigation``: a receiver of its signed events (``receiver``),
a small real NavigateToPose server (``python -m robot_stack_testing.navigation.nav2_server``)
and the credential-less ROS intruder of issue 35 (``python -m
robot_stack_testing.navigation.intruder``). Need rclpy and nav2_msgs (the ROS wheels)."""
