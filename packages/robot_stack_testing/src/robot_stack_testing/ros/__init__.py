"""Test doubles at the ROS boundary of ``robot_ros_bridge``: a real rclpy fake vision node and
its in-memory VisionTasks (``fake_vision``; ``python -m robot_stack_testing.ros.fake_vision``
runs the node as its own process). Needs the ROS wheels and the vision interfaces installed."""
