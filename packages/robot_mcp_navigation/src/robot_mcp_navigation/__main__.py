from robot_mcp_navigation.server import main

main()
