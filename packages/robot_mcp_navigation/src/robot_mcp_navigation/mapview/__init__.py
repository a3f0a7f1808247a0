"""What the robot's own map shows: map_server's ``/map``, Nav2's global costmap and ``/plan``
(the MapView port, its rclpy adapter and the rendering of a grid for displays)."""
