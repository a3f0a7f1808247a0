"""Shared contract of the capability servers: task events, HMAC signing, the event poster and MCP server plumbing."""
