"""MCP server storing taught processes (SQLite FTS5 by default)."""
