"""Message ↔ domain conversions, tested by building messages directly."""

from __future__ import annotations

import json

import numpy as np
import pytest
from sensor_msgs.msg import Image as ImageMsg
from std_msgs.msg import Header

from robot_mcp_perception.conversions import (
    ImageEncodingError,
    detection_to_msg,
    image_msg_to_rgb,
    mask_from_image_msg,
    mask_to_image_msg,
    ns_to_stamp,
    output_to_msg,
    rgb_to_image_msg,
    stamp_to_ns,
)
from robot_mcp_perception.pipelines.common import Detection

HEADER = Header(stamp=ns_to_stamp(12_000_000_034), frame_id="cam")


def test_stamp_round_trips_through_nanoseconds() -> None:
    assert stamp_to_ns(ns_to_stamp(12_000_000_034)) == 12_000_000_034


def test_rgb_image_round_trips_and_data_is_bytes_backed() -> None:
    image = np.random.default_rng(0).integers(0, 255, (6, 8, 3), dtype=np.uint8)

    msg = rgb_to_image_msg(image, HEADER)

    assert (msg.encoding, msg.step, msg.header.frame_id) == ("rgb8", 24, "cam")
    np.testing.assert_array_equal(image_msg_to_rgb(msg), image)


@pytest.mark.parametrize("encoding", ["bgr8", "bgra8", "mono8"])
def test_other_camera_encodings_become_rgb(encoding: str) -> None:
    channels = {"bgr8": 3, "bgra8": 4, "mono8": 1}[encoding]
    pixel = [10, 20, 30, 40][:channels]
    data = bytes(pixel * 4)
    msg = ImageMsg(height=2, width=2, encoding=encoding, step=2 * channels, data=data)

    rgb = image_msg_to_rgb(msg)

    expected = [10, 10, 10] if encoding == "mono8" else [30, 20, 10]
    assert rgb.shape == (2, 2, 3)
    assert rgb[0, 0].tolist() == expected


def test_unsupported_or_truncated_images_are_rejected() -> None:
    with pytest.raises(ImageEncodingError):
        image_msg_to_rgb(ImageMsg(height=1, width=1, encoding="yuv422", step=2, data=b"ab"))
    with pytest.raises(ImageEncodingError):
        image_msg_to_rgb(ImageMsg(height=4, width=4, encoding="rgb8", step=12, data=b"abc"))


def test_masks_are_mono8_full_frame_0_or_255() -> None:
    mask = np.zeros((4, 5), dtype=bool)
    mask[1, 2] = True

    msg = mask_to_image_msg(mask, HEADER)

    assert (msg.encoding, msg.height, msg.width, msg.step) == ("mono8", 4, 5, 5)
    assert sorted(set(bytes(msg.data))) == [0, 255]
    np.testing.assert_array_equal(mask_from_image_msg(msg), mask)
    with pytest.raises(ImageEncodingError):
        mask_from_image_msg(rgb_to_image_msg(np.zeros((1, 1, 3), np.uint8), HEADER))


def test_detection_message_with_and_without_mask() -> None:
    mask = np.ones((3, 3), dtype=bool)
    det = Detection("mug", 0.75, "object", (1, 2, 4, 6), mask, (2, 3), {"k": 1})

    full = detection_to_msg(det, HEADER, with_mask=True, extra={"stale": True})
    meta = detection_to_msg(det, HEADER, with_mask=False, extra={})

    assert (full.box.x_offset, full.box.y_offset, full.box.width, full.box.height) == (1, 2, 3, 4)
    assert (full.point.x, full.point.y) == (2.0, 3.0)
    assert len(full.mask.data) == 9
    assert json.loads(full.extra) == {"k": 1, "stale": True}
    assert len(meta.mask.data) == 0
    assert meta.label == "mug"
    assert meta.score == pytest.approx(0.75)


def test_semantic_outputs_are_json_encoded() -> None:
    assert output_to_msg(True, HEADER).data == "true"
    assert json.loads(output_to_msg(["cup", "box"], HEADER).data) == ["cup", "box"]
    assert json.loads(output_to_msg("a red mug", HEADER).data) == "a red mug"
