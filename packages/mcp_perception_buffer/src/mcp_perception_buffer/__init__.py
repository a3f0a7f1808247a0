"""MCP server holding a rolling buffer of what the vision node published (the brain's eyes)."""
