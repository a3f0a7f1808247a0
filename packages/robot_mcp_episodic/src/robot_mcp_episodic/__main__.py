"""``python -m robot_mcp_episodic``: same as the console script."""

from robot_mcp_episodic.composition import main

main()
