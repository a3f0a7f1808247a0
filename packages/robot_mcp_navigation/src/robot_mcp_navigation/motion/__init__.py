"""The robot-motion port (MotionBase) and its adapters."""
