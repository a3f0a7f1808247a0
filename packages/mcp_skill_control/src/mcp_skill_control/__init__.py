"""MCP server that instantiates vision skills on the vision node (the brain's hands)."""
