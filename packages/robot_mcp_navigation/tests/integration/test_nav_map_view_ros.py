"""RclpyMapView over ROS: /map and the global costmap (map_server's latched QoS: a late
subscriber gets them) and /plan, published by another node, arrive with their frames."""

from __future__ import annotations

import pytest

from robot_mcp_navigation.mapview.rclpy_view import LATCHED, PLAN_QOS, RclpyMapView
from robot_ros_bridge import RosBridge
from robot_stack_testing import wait_until

pytestmark = pytest.mark.ros


def test_the_map_view_receives_the_latched_map_and_costmap_and_the_plan() -> None:
    from geometry_msgs.msg import PoseStamped
    from nav_msgs.msg import OccupancyGrid, Path

    with RosBridge("fake_map_server").start() as robot, RosBridge("map_view_test").start() as ours:
        grid = OccupancyGrid()
        grid.header.frame_id = "map"
        grid.info.resolution, grid.info.width, grid.info.height = 0.05, 3, 2
        grid.info.origin.position.x, grid.info.origin.position.y = -2.5, -6.5
        grid.data = [0, 100, -1, 0, 0, 100]
        robot.create_publisher(OccupancyGrid, "/map", LATCHED).publish(grid)  # before we subscribe
        costmap = robot.create_publisher(OccupancyGrid, "/global_costmap/costmap", LATCHED)
        costmap.publish(grid)
        plans = robot.create_publisher(Path, "/plan", PLAN_QOS)

        view = RclpyMapView(ours, "/map", "/global_costmap/costmap", "/plan")
        wait_until(lambda: view.map() is not None and view.costmap() is not None, 15, "the map")
        path = Path()
        path.header.frame_id = "map"
        for x in (0.0, 1.0, 2.0):
            pose = PoseStamped()
            pose.header.frame_id = "map"
            pose.pose.position.x = x
            path.poses.append(pose)

        def planned() -> bool:
            plans.publish(path)  # volatile: published until the subscription has matched
            return view.plan() is not None

        wait_until(planned, 15, "the plan")

    snapshot = view.map()
    assert snapshot is not None
    assert (snapshot.frame, snapshot.width, snapshot.height) == ("map", 3, 2)
    assert snapshot.origin == (-2.5, -6.5)
    assert list(snapshot.cells) == [0, 100, 255, 0, 0, 100]  # int8 −1 as a byte
    plan = view.plan()
    assert plan is not None
    assert (plan.frame, plan.points) == ("map", ((0.0, 0.0), (1.0, 0.0), (2.0, 0.0)))
