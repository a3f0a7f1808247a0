"""A ROS peer that plays the intruder of issue 35's review, for tests and benchmarks: a plain
rclpy process in the robot's ROS domain, with no credential of any kind.

- ``--lock-topic T --lock-hz 200``: publishes ``false`` (open) on a lock topic at that rate;
- ``--goal X,Y``: sends a NavigateToPose goal straight to the base (``--action``), and reports
  its acceptance and its end;
- ``--pose X,Y``: publishes a fake pose on ``/amcl_pose`` (``--pose-topic``) at 10 Hz;
- ``--map``: publishes a fake map on ``/map`` (``--map-topic``), latched;
- ``--wait-for FILE``: starts (creates its publishers, sends its goal) only once FILE exists, so
  a benchmark can time the intrusion itself, not the interpreter's start.

It runs ``--seconds`` (or until SIGTERM) and prints one JSON object per line on stdout, flushed:
``{"event": "intruder_ready"}``, ``goal_accepted`` / ``goal_rejected``, ``goal_ended`` with
``status`` (``canceled``, ``succeeded``, ``aborted``) — what tests and benchmarks read.

Run: ``python -m robot_stack_testing.navigation.intruder --lock-topic /robot/supervisor_lock
--goal 17,3 --seconds 30``
"""

from __future__ import annotations

import argparse
import json
import math
import signal
import sys
import threading
import time
from pathlib import Path
from typing import Any

STATUS = {4: "succeeded", 5: "canceled", 6: "aborted"}


def say(event: str, **fields: Any) -> None:
    sys.stdout.write(json.dumps({"event": event, "wall": time.time(), **fields}) + "\n")
    sys.stdout.flush()


def _pair(text: str) -> tuple[float, float]:
    x, y = (float(v) for v in text.split(","))
    return x, y


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--lock-topic", default="")
    parser.add_argument("--lock-hz", type=float, default=200.0)
    parser.add_argument("--goal", type=_pair, default=None)
    parser.add_argument("--action", default="/navigate_to_pose")
    parser.add_argument("--pose", type=_pair, default=None)
    parser.add_argument("--pose-topic", default="/amcl_pose")
    parser.add_argument("--map", action="store_true")
    parser.add_argument("--map-topic", default="/map")
    parser.add_argument("--node-name", default="intruder")
    parser.add_argument("--seconds", type=float, default=60.0)
    parser.add_argument(
        "--wait-for", default="", help="a file: start intruding once it exists (warmed up)"
    )
    args = parser.parse_args(argv)

    import rclpy
    from geometry_msgs.msg import PoseWithCovarianceStamped
    from nav2_msgs.action import NavigateToPose
    from nav_msgs.msg import OccupancyGrid
    from rclpy.action.client import ActionClient
    from rclpy.executors import ExternalShutdownException, MultiThreadedExecutor
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
    from std_msgs.msg import Bool

    from robot_ros_bridge.spinning import drain_callbacks

    rclpy.init()
    node = rclpy.create_node(args.node_name)
    stop = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    if args.wait_for:
        say("intruder_waiting")
        while not Path(args.wait_for).exists() and not stop.is_set():
            time.sleep(0.005)
    latched = QoSProfile(
        depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL
    )
    if args.lock_topic:
        lock_qos = QoSProfile(
            depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE
        )
        lock = node.create_publisher(Bool, args.lock_topic, lock_qos)
        node.create_timer(1.0 / args.lock_hz, lambda: lock.publish(Bool(data=False)))
    if args.pose is not None:
        pose_pub = node.create_publisher(PoseWithCovarianceStamped, args.pose_topic, latched)
        fake = PoseWithCovarianceStamped()
        fake.header.frame_id = "map"
        fake.pose.pose.position.x, fake.pose.pose.position.y = args.pose
        fake.pose.pose.orientation.w = 1.0

        def publish_pose() -> None:
            fake.header.stamp = node.get_clock().now().to_msg()
            pose_pub.publish(fake)

        node.create_timer(0.1, publish_pose)
    if args.map:
        map_pub = node.create_publisher(OccupancyGrid, args.map_topic, latched)
        grid = OccupancyGrid()
        grid.header.frame_id = "map"
        grid.info.resolution, grid.info.width, grid.info.height = 0.5, 4, 4
        grid.data = [0] * 16
        map_pub.publish(grid)
    executor = MultiThreadedExecutor(num_threads=2)
    executor.add_node(node)
    spinner = threading.Thread(
        target=_spin, args=(executor, stop, ExternalShutdownException), daemon=True
    )
    spinner.start()
    say("intruder_ready", node=args.node_name)
    client: Any = ActionClient(node, NavigateToPose, args.action) if args.goal is not None else None
    try:
        if client is not None:
            _send_goal(node, client, args.goal, stop)
        stop.wait(max(0.0, args.seconds))
    finally:
        # Nothing is destroyed while the executor may still use it: the spin loop ends first,
        # then the executor (rclpy's shutdown destroys its guard condition at once, under a spin
        # thread still waiting on it: a segfault on a busy machine), then the node.
        stop.set()
        spinner.join(timeout=10)
        drain_callbacks(executor, 5.0)
        executor.shutdown(timeout_sec=5)
        if client is not None:
            client.destroy()
        node.destroy_node()
        rclpy.try_shutdown()
        say("intruder_stopped")


def _spin(executor: Any, stop: threading.Event, shutdown: type[BaseException]) -> None:
    from robot_ros_bridge.spinning import spin_until_shutdown

    try:
        spin_until_shutdown(executor, lambda: not stop.is_set(), turn_s=0.1)
    except shutdown:
        return


def _send_goal(node: Any, client: Any, xy: tuple[float, float], stop: threading.Event) -> None:
    from nav2_msgs.action import NavigateToPose

    if not client.wait_for_server(timeout_sec=30.0):
        say("goal_no_server")
        return
    goal = NavigateToPose.Goal()
    goal.pose.header.frame_id = "map"
    goal.pose.header.stamp = node.get_clock().now().to_msg()
    goal.pose.pose.position.x, goal.pose.pose.position.y = xy
    goal.pose.pose.orientation.w = math.cos(0.0)
    sent = client.send_goal_async(goal)

    def on_answer(future: Any) -> None:
        handle = future.result()
        if not handle.accepted:
            say("goal_rejected")
            return
        say("goal_accepted", x=xy[0], y=xy[1])
        handle.get_result_async().add_done_callback(
            lambda done: say("goal_ended", status=STATUS.get(int(done.result().status), "unknown"))
        )

    sent.add_done_callback(on_answer)
    say("goal_sent", x=xy[0], y=xy[1])


if __name__ == "__main__":
    main()
