"""The ingest benchmark's baseline: a bare rclpy process that subscribes raw (CDR bytes, no
decode) to the same topics as the episodic server, through the same ``RosBridge`` (one node;
``multi_threaded`` or ``single_threaded`` executor), and does nothing with the messages. Its
CPU, measured in the same window as the server's, is what rclpy + DDS cost on this machine at
this load; the server's CPU minus it is what the episodic work costs.

    python benchmarks/_episodic_bare_subscriber.py EXECUTOR POSE_TOPIC SKILL [SKILL ...]
"""

from __future__ import annotations

import signal
import sys
import threading

from robot_ros_bridge import RosBridge


def main() -> None:
    from geometry_msgs.msg import PoseWithCovarianceStamped
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    from ros2_vision_interfaces.msg import VisionDetectionArray

    executor, pose_topic, *skills = sys.argv[1:]
    if executor not in ("multi_threaded", "single_threaded"):
        raise SystemExit(f"unknown executor {executor!r}")
    qos = QoSProfile(depth=50, reliability=ReliabilityPolicy.BEST_EFFORT)
    received = [0]

    def count(_data: bytes) -> None:
        received[0] += 1

    stop = threading.Event()
    signal.signal(signal.SIGINT, lambda *_: stop.set())
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    with RosBridge(f"episodic_bench_bare_{executor}", executor=executor) as bridge:
        bridge.create_subscription(PoseWithCovarianceStamped, pose_topic, count, qos, raw=True)
        for skill in skills:
            bridge.create_subscription(
                VisionDetectionArray, f"/vision/{skill}/detections_meta", count, qos, raw=True
            )
        print("bare_subscriber_ready", flush=True)
        stop.wait()
    print(f"bare_subscriber_received {received[0]}", flush=True)


if __name__ == "__main__":
    main()
