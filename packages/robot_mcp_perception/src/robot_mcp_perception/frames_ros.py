"""The on-robot frame source: a ``sensor_msgs/Image`` camera topic (BEST_EFFORT, depth 1)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import structlog
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import Image as ImageMsg

from robot_mcp_perception.conversions import ImageEncodingError, image_msg_to_rgb, stamp_to_ns
from robot_mcp_perception.frames import FrameListener, FrameSource, downscale

if TYPE_CHECKING:
    from rclpy.node import Node

logger = structlog.get_logger("robot_mcp_perception.frames")

CAMERA_QOS = QoSProfile(
    depth=1, reliability=ReliabilityPolicy.BEST_EFFORT, history=HistoryPolicy.KEEP_LAST
)


class RosFrameSource(FrameSource):
    """Subscribes ``topic``; the header stamp and frame_id travel with the frame."""

    def __init__(self, topic: str = "/camera/image_raw", max_side: int = 1280, **_: Any) -> None:
        super().__init__(frame_id="")
        self.topic = topic
        self.max_side = max_side
        self.rejected = 0
        self._node: Node | None = None
        self._subscription: Any = None

    def start(self, node: Node | None, on_frame: FrameListener | None = None) -> None:
        if node is None:
            raise ValueError("the ros frame source needs the node to subscribe with")
        self._node = node
        self._listener = on_frame
        self._subscription = node.create_subscription(
            ImageMsg, self.topic, self.on_image, CAMERA_QOS
        )

    def stop(self) -> None:
        if self._node is not None and self._subscription is not None:
            self._node.destroy_subscription(self._subscription)
        self._subscription = None

    def on_image(self, msg: ImageMsg) -> None:
        try:
            image = image_msg_to_rgb(msg)
        except ImageEncodingError as error:
            self.rejected += 1
            logger.warning("frame_rejected", topic=self.topic, error=str(error))
            return
        self._emit(
            downscale(image, self.max_side), stamp_to_ns(msg.header.stamp), msg.header.frame_id
        )
