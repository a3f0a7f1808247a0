"""robot-mcp-manipulation: the robot's arm and gripper as an async MCP capability."""
