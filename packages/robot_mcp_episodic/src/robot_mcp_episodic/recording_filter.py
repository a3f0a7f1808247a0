"""Which recorded messages a label-or-place ``forget`` removes: a skill's detections message
inside one of the forgotten intervals that shows the forgotten label (the whole frame goes;
it is decoded with ``mcap-ros2-support`` from the schema the bag stores)."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

from mcap.records import Schema
from mcap_ros2.decoder import DecoderFactory

from robot_mcp_episodic.msgdefs import message_definition

META_TYPE = "ros2_vision_interfaces/msg/VisionDetectionArray"

# (skill, label, start s, end s) of one forgotten sighting interval.
Window = tuple[str, str, float, float]


def meta_topic(skill: str) -> str:
    return f"/vision/{skill}/detections_meta"


def _decoder() -> Callable[[bytes], Any]:
    schema = Schema(
        id=1, name=META_TYPE, encoding="ros2msg", data=message_definition(META_TYPE).encode()
    )
    decoder = DecoderFactory().decoder_for("cdr", schema)
    assert decoder is not None
    return decoder


def sighting_selector(windows: Sequence[Window]) -> Callable[[str, int, bytes], bool]:
    by_topic: dict[str, list[tuple[str, int, int]]] = {}
    for skill, label, start, end in windows:
        by_topic.setdefault(meta_topic(skill), []).append((label, int(start * 1e9), int(end * 1e9)))
    decode = _decoder()

    def selected(topic: str, stamp_ns: int, data: bytes) -> bool:
        labels = {label for label, low, high in by_topic.get(topic, ()) if low <= stamp_ns <= high}
        if not labels:
            return False
        message = decode(data)
        return any(det.label in labels for det in message.detections)

    return selected
