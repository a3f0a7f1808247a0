from robot_mcp_manipulation.server import main

main()
