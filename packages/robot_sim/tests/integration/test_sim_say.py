"""robot-sim-say (issue 36): a sentence spoken by espeak-ng reaches the microphone topic in
audio_common's ROS 2 messages, with the stream's AudioInfo latched beside it."""

from __future__ import annotations

import shutil
import threading

import numpy as np
import pytest
import rclpy
from audio_common_msgs.msg import AudioDataStamped, AudioInfo
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

from robot_sim.say import AUDIO_TOPIC, INFO_TOPIC, RATE, main, room, speech
from robot_stack_testing import wait_until

pytestmark = [
    pytest.mark.ros,
    pytest.mark.skipif(shutil.which("espeak-ng") is None, reason="espeak-ng is not installed"),
]


def test_the_spoken_sentence_arrives_on_the_audio_topic() -> None:
    context = Context()
    rclpy.init(context=context)
    node = rclpy.create_node("say_listener", context=context)
    chunks: list[bytes] = []
    infos: list[AudioInfo] = []
    node.create_subscription(
        AudioDataStamped, AUDIO_TOPIC, lambda m: chunks.append(bytes(m.audio.data)), 50
    )
    latched = QoSProfile(
        depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL, reliability=ReliabilityPolicy.RELIABLE
    )
    node.create_subscription(AudioInfo, INFO_TOPIC, infos.append, latched)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    spinner = threading.Thread(target=executor.spin, daemon=True)
    spinner.start()
    try:
        assert main(["go to the kitchen", "--silence-s", "0.3", "--wait-s", "20"]) == 0
        expected = room(speech("go to the kitchen"), None, 0.3)
        wait_until(lambda: sum(len(c) for c in chunks) >= expected.size * 2, timeout_s=10)
        heard = np.frombuffer(b"".join(chunks), dtype="<i2")
        assert heard.size == expected.size
        assert np.abs(heard.astype(np.int32)).max() > 3000  # speech, not silence
        wait_until(lambda: bool(infos), timeout_s=10)
        info = infos[-1]
        assert (info.channels, info.sample_rate, info.sample_format) == (1, RATE, "S16LE")
        assert info.coding_format == "WAVE"
    finally:
        executor.shutdown(timeout_sec=1.0)
        node.destroy_node()
        rclpy.try_shutdown(context=context)
        spinner.join(timeout=5)


def test_noise_is_mixed_in_at_the_asked_ratio() -> None:
    pcm = speech("stop")
    noisy = room(pcm, 10.0, 0.0)
    residue = noisy.astype(np.float64) - pcm.astype(np.float64)
    snr = 10 * np.log10(np.mean(pcm.astype(np.float64) ** 2) / np.mean(residue**2))
    assert 9.0 < snr < 11.0
