from robot_sim.main import main

main()
