"""asyncio <-> rclpy bridge used by the MCP servers that talk ROS."""
