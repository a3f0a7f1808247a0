"""Honest MCP tool annotations shared by our servers (hints a host uses to decide what to ask).

Hosts read them to decide what needs a person's yes (the brain's policy defaults come from
them: read-only → allow, destructive → confirm). Unset hints mean the MCP defaults (not
read-only, destructive), so every tool of ours sets them explicitly.
"""

from __future__ import annotations

from mcp.types import ToolAnnotations

READ_ONLY = ToolAnnotations(read_only_hint=True, open_world_hint=False)
"""Observes only (state, buffers, stored documents)."""

STOPS = ToolAnnotations(
    read_only_hint=False, destructive_hint=False, idempotent_hint=True, open_world_hint=False
)
"""Stops or cancels something; calling it again changes nothing more."""

RECORDS = ToolAnnotations(read_only_hint=False, destructive_hint=False, open_world_hint=False)
"""Adds a record or starts an observation; overwrites nothing."""

DELETES = ToolAnnotations(
    read_only_hint=False, destructive_hint=True, idempotent_hint=True, open_world_hint=False
)
"""Deletes stored records for good: hosts should ask before calling it."""

MOVES_ROBOT = ToolAnnotations(
    read_only_hint=False, destructive_hint=True, idempotent_hint=False, open_world_hint=True
)
"""Moves the robot among people and things: hosts should ask before calling it."""

CONFIGURES_FREELY = ToolAnnotations(
    read_only_hint=False, destructive_hint=True, idempotent_hint=False, open_world_hint=True
)
"""Runs arbitrary configuration the host wrote itself (no vetted template)."""
