"""Episodic memory of the robot: what it saw, where it was and what happened."""
