"""Test doubles of ``robot_mcp_kit``'s peers: a signature-checking receiver of posted TaskEvents
(``receiver``, the brain's ``POST /api/agent/events`` as seen by a poster) and the reading of a
kit tool's answer and an approved call's ``_meta`` (``tool_calls``)."""
