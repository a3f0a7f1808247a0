from robot_mcp_memory.server import main

main()
