"""The ROS 2 vision node: runtime-configured skills, a grounder and a segmenter, results on
/vision/**."""
