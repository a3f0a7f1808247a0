"""A small real NavigateToPose action server (rclpy) for cross-process tests: what Nav2's
bt_navigator looks like from outside, and nothing more.

- accepts goals in the ``map`` frame (rejects others), drives a straight line at ``--speed``
  m/s, feedback at 20 Hz (current_pose, distance_remaining, estimated_time_remaining,
  navigation_time, number_of_recoveries), SUCCEEDED on arrival;
- ``--abort X,Y,CODE,MESSAGE``: a goal at (X, Y) is ABORTED half way with that error code;
- cancel → CANCELED at once; prints ``goal_canceled`` (the tests read this log line);
- ``--trace``: also prints ``trace <what> ... wall=<time.time()>`` for each goal received, feedback
  sent and goal canceled (benchmarks/navigation_nav2.py reads them);
- publishes the pose on ``/amcl_pose`` (PoseWithCovarianceStamped, reliable + transient local,
  depth 1, as AMCL does) at 10 Hz.

Run: ``python -m robot_stack_testing.navigation.nav2_server --start 0,0 --speed 2.0
[--abort 17,3,208,"door closed"]``
"""

from __future__ import annotations

import argparse
import math
import signal
import sys
import threading
import time
from typing import Any

import rclpy
from geometry_msgs.msg import PoseWithCovarianceStamped
from nav2_msgs.action import NavigateToPose
from rclpy.action.server import ActionServer, CancelResponse, GoalResponse, ServerGoalHandle
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.executors import ExternalShutdownException, MultiThreadedExecutor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

FEEDBACK_PERIOD_S = 0.05


def say(line: str, flush: bool = True) -> None:
    """One line on stdout: what the tests read from this server's log."""
    sys.stdout.write(line + "\n")
    if flush:
        sys.stdout.flush()


def duration(seconds: float) -> Any:
    from builtin_interfaces.msg import Duration

    whole = int(seconds)
    return Duration(sec=whole, nanosec=int((seconds - whole) * 1e9))


class FakeNav2(Node):
    def __init__(
        self,
        start: tuple[float, float],
        speed: float,
        aborts: dict[Any, Any],
        trace: bool = False,
    ) -> None:
        super().__init__("fake_nav2")
        self.trace = trace
        self.cancel_asked: dict[bytes, threading.Event] = {}
        self.x, self.y = start
        self.speed = speed
        self.aborts = aborts
        self.lock = threading.Lock()
        group = ReentrantCallbackGroup()
        self.server = ActionServer(
            self,
            NavigateToPose,
            "/navigate_to_pose",
            self.execute,
            goal_callback=self.on_goal,
            cancel_callback=self.on_cancel,
            callback_group=group,
        )
        qos = QoSProfile(
            depth=1,
            reliability=ReliabilityPolicy.RELIABLE,
            durability=DurabilityPolicy.TRANSIENT_LOCAL,
        )
        self.pose_pub = self.create_publisher(PoseWithCovarianceStamped, "/amcl_pose", qos)
        self.create_timer(0.1, self.publish_pose, callback_group=group)

    def publish_pose(self) -> None:
        msg = PoseWithCovarianceStamped()
        msg.header.frame_id = "map"
        msg.header.stamp = self.get_clock().now().to_msg()
        with self.lock:
            msg.pose.pose.position.x, msg.pose.pose.position.y = self.x, self.y
        msg.pose.pose.orientation.w = 1.0
        self.pose_pub.publish(msg)

    def on_goal(self, request: Any) -> GoalResponse:
        frame = request.pose.header.frame_id
        if self.trace:
            say(f"trace goal_received wall={time.time():.6f}")
        say(f"goal_received frame={frame}")
        return GoalResponse.ACCEPT if frame == "map" else GoalResponse.REJECT

    def on_cancel(self, goal: ServerGoalHandle[Any, Any, Any]) -> CancelResponse:
        self.cancel_asked.setdefault(bytes(goal.goal_id.uuid), threading.Event()).set()
        return CancelResponse.ACCEPT

    def execute(self, goal: ServerGoalHandle[Any, Any, Any]) -> Any:
        target = goal.request.pose.pose.position
        with self.lock:
            origin = (self.x, self.y)
        total = math.hypot(target.x - origin[0], target.y - origin[1])
        abort = self.aborts.get((round(target.x, 2), round(target.y, 2)))
        started = time.monotonic()
        result = NavigateToPose.Result()
        deadline = started + total / self.speed + 60.0
        cancel_asked = self.cancel_asked.setdefault(bytes(goal.goal_id.uuid), threading.Event())
        while time.monotonic() < deadline:
            if goal.is_cancel_requested:
                goal.canceled()
                if self.trace:
                    say(f"trace goal_canceled wall={time.time():.6f}")
                say("goal_canceled")
                return result
            # Nav2 reports navigation_time; in 10 ms steps here so a benchmark can find the
            # feedback an event came from (the navigator rounds elapsed_s to 0.01).
            elapsed = round(time.monotonic() - started, 2)
            fraction = 1.0 if total == 0 else min(1.0, elapsed * self.speed / total)
            if abort is not None and fraction >= 0.5:
                result.error_code, result.error_msg = abort
                goal.abort()
                say(f"goal_aborted code={abort[0]}")
                return result
            with self.lock:
                self.x = origin[0] + (target.x - origin[0]) * fraction
                self.y = origin[1] + (target.y - origin[1]) * fraction
            remaining = total * (1.0 - fraction)
            feedback = NavigateToPose.Feedback()
            feedback.current_pose.header.frame_id = "map"
            feedback.current_pose.pose.position.x = self.x
            feedback.current_pose.pose.position.y = self.y
            feedback.current_pose.pose.orientation.w = 1.0
            feedback.distance_remaining = float(remaining)
            feedback.estimated_time_remaining = duration(remaining / self.speed)
            feedback.navigation_time = duration(elapsed)
            goal.publish_feedback(feedback)
            if self.trace:
                say(f"trace feedback nav_time={elapsed:.2f} wall={time.time():.6f}", flush=False)
            if fraction >= 1.0:
                goal.succeed()
                say("goal_succeeded")
                return result
            if cancel_asked.wait(FEEDBACK_PERIOD_S):  # the control loop's period, cut short
                settle = time.monotonic() + 1.0  # by a cancel (CANCELING follows its callback)
                while not goal.is_cancel_requested and time.monotonic() < settle:
                    time.sleep(0.001)
        result.error_code = NavigateToPose.Result.TIMEOUT
        goal.abort()
        return result


def parse_abort(text: str) -> tuple[tuple[float, float], tuple[int, str]]:
    x, y, code, message = text.split(",", 3)
    return (round(float(x), 2), round(float(y), 2)), (int(code), message)


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--start", default="0,0")
    parser.add_argument("--speed", type=float, default=2.0)
    parser.add_argument("--abort", action="append", default=[])
    parser.add_argument("--trace", action="store_true")
    args = parser.parse_args()
    sx, sy = (float(v) for v in args.start.split(","))
    rclpy.init()
    node = FakeNav2(
        (sx, sy), args.speed, dict(parse_abort(a) for a in args.abort), trace=args.trace
    )
    executor = MultiThreadedExecutor(num_threads=4)
    executor.add_node(node)
    signal.signal(signal.SIGTERM, lambda *_: rclpy.try_shutdown())
    say("fake_nav2_ready")
    try:
        executor.spin()
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == "__main__":
    main()
