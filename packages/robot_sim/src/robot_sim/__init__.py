"""robot_sim: a simulated robot that speaks ROS 2 the way a Nav2 robot does."""
