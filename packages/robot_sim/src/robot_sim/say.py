"""``robot-sim-say``: a person in the office says a sentence to the robot (issue 36).

    robot-sim-say "go to the kitchen"
    robot-sim-say --voice en-gb-scotland --noise-snr 10 "fetch the package from the mailroom"

The sentence is spoken by espeak-ng (argv, never a shell), resampled to 16 kHz mono S16LE and
published in real time on the robot's microphone topic, in audio_common's ROS 2 messages
(ros-drivers/audio_common 0.3.12, interfaces/audio_common_msgs): ``/audio_stamped``
(``AudioDataStamped``, one chunk per ``--chunk-ms``) and ``/audio_info`` (``AudioInfo``,
transient local: 1 channel, 16000 Hz, S16LE, WAVE), with ``--silence-s`` of room noise before
and after. ``--noise-snr`` mixes pink noise in (an office: fans, people). Exit 0 once every
chunk was published (after ``--wait-s`` for a subscriber), 1 when espeak-ng failed.
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import time
import wave
from collections.abc import Sequence
from io import BytesIO

import numpy as np

RATE = 16_000
AUDIO_TOPIC = "/audio_stamped"
INFO_TOPIC = "/audio_info"


def speech(text: str, voice: str = "en-us", speed: int = 160) -> np.ndarray:
    """``text`` spoken by espeak-ng as 16 kHz mono int16."""
    wav = subprocess.run(  # noqa: S603 - argv list, the text is one argument
        ["espeak-ng", "-v", voice, "-s", str(speed), "--stdout", text],  # noqa: S607 - apt
        capture_output=True,
        check=True,
        timeout=30,
    ).stdout
    with wave.open(BytesIO(wav)) as reader:
        rate = reader.getframerate()
        samples = np.frombuffer(reader.readframes(reader.getnframes()), dtype="<i2")
    times = np.arange(int(samples.size * RATE / rate)) / RATE
    resampled = np.interp(times, np.arange(samples.size) / rate, samples.astype(np.float64))
    return np.asarray(resampled, dtype=np.int16)


def room(pcm: np.ndarray, snr_db: float | None, silence_s: float, seed: int = 0) -> np.ndarray:
    """``pcm`` with ``silence_s`` before and after, and pink noise at ``snr_db`` (None: a quiet
    room, a little white noise as any microphone has)."""
    pad = np.zeros(int(silence_s * RATE))
    signal = np.concatenate([pad, pcm.astype(np.float64), pad])
    rng = np.random.default_rng(seed)
    if snr_db is None:
        signal += rng.standard_normal(signal.size) * 8.0
    else:
        spectrum = np.fft.rfft(rng.standard_normal(signal.size))
        spectrum /= np.sqrt(np.arange(1, spectrum.size + 1))
        noise = np.fft.irfft(spectrum, signal.size)
        power = float(np.mean(pcm.astype(np.float64) ** 2)) or 1.0
        signal += noise / (float(np.std(noise)) or 1.0) * np.sqrt(power / 10 ** (snr_db / 10))
    return np.asarray(np.clip(signal, -32768, 32767), dtype=np.int16)


def chunks(pcm: np.ndarray, chunk_ms: int) -> list[bytes]:
    size = max(1, RATE * chunk_ms // 1000)
    data = pcm.astype("<i2").tobytes()
    step = size * 2
    return [data[i : i + step] for i in range(0, len(data), step)]


def publish(
    pcm: np.ndarray, chunk_ms: int, wait_s: float, topic: str = AUDIO_TOPIC, realtime: bool = True
) -> int:
    """Publish ``pcm`` as audio_common messages; returns the number of chunks sent."""
    import rclpy
    from audio_common_msgs.msg import AudioDataStamped, AudioInfo
    from rclpy.context import Context
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

    context = Context()
    rclpy.init(context=context)
    node = rclpy.create_node("robot_sim_say", context=context)
    try:
        latched = QoSProfile(
            depth=1,
            durability=DurabilityPolicy.TRANSIENT_LOCAL,
            reliability=ReliabilityPolicy.RELIABLE,
        )
        info_publisher = node.create_publisher(AudioInfo, INFO_TOPIC, latched)
        audio = node.create_publisher(AudioDataStamped, topic, 50)
        info = AudioInfo(
            channels=1, sample_rate=RATE, sample_format="S16LE", bitrate=RATE * 16,
            coding_format="WAVE",
        )  # fmt: skip
        info_publisher.publish(info)
        deadline = time.monotonic() + wait_s
        while audio.get_subscription_count() == 0 and time.monotonic() < deadline:
            time.sleep(0.05)  # a CLI: wait until the listener is matched
        pieces = chunks(pcm, chunk_ms)
        started = time.monotonic()
        for index, piece in enumerate(pieces):
            message = AudioDataStamped()
            message.header.stamp = node.get_clock().now().to_msg()
            message.header.frame_id = "microphone"
            message.audio.data = piece
            audio.publish(message)
            if realtime:  # a microphone delivers its chunks as the time passes
                due = started + (index + 1) * chunk_ms / 1000
                time.sleep(max(0.0, due - time.monotonic()))
        return len(pieces)
    finally:
        node.destroy_node()
        rclpy.try_shutdown(context=context)


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="robot-sim-say", description=__doc__.splitlines()[0])
    parser.add_argument("text", help="what the person says")
    parser.add_argument("--voice", default="en-us", help="espeak-ng voice (en-us, en-gb-scotland…)")
    parser.add_argument("--speed", type=int, default=160, help="words per minute")
    parser.add_argument("--noise-snr", type=float, default=None, help="pink noise, dB SNR")
    parser.add_argument("--silence-s", type=float, default=0.5, help="room before and after")
    parser.add_argument("--chunk-ms", type=int, default=100)
    parser.add_argument("--topic", default=AUDIO_TOPIC)
    parser.add_argument("--wait-s", type=float, default=5.0, help="for a listener to match")
    args = parser.parse_args(argv)
    if shutil.which("espeak-ng") is None:
        sys.stderr.write("robot-sim-say: espeak-ng is not installed (apt install espeak-ng)\n")
        return 1
    try:
        pcm = speech(args.text, args.voice, args.speed)
    except (subprocess.SubprocessError, OSError, wave.Error) as exc:
        sys.stderr.write(f"robot-sim-say: espeak-ng failed: {exc}\n")
        return 1
    sent = publish(
        room(pcm, args.noise_snr, args.silence_s), args.chunk_ms, args.wait_s, args.topic
    )
    sys.stdout.write(f"said {args.text!r} on {args.topic}: {sent} chunks of {args.chunk_ms} ms\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
