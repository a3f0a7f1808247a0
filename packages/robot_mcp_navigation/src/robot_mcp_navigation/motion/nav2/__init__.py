"""The Nav2 motion adapter: ``Nav2MotionBase`` over the ``Nav2Action`` port (``NavigateToPose``
action client + pose topic), with the rclpy adapter of that port and a fake for tests."""
