"""``python -m mcp_skill_control``: same as the console script."""

from mcp_skill_control.composition import main

main()
