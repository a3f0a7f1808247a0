"""MCP server for the robot base; ships a simulated base on a map file."""
