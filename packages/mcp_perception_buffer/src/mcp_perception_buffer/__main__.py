"""``python -m mcp_perception_buffer``: same as the console script."""

from mcp_perception_buffer.composition import main

main()
