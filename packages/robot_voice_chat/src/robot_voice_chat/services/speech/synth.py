"""Speech made on the spot with espeak-ng (a person's voice for tests and benchmarks): text →
16 kHz mono int16, optionally with pink noise (an office: fans, people, traffic)."""

from __future__ import annotations

import shutil
import subprocess

import numpy as np

from robot_voice_chat.services.speech.audio import decode

VOICES = ("en-us", "en-gb-scotland", "en-us+f3", "en-029", "en-gb-x-rp")


def espeak_available() -> bool:
    return shutil.which("espeak-ng") is not None


def say(text: str, voice: str = "en-us", speed: int = 160, timeout_s: float = 20.0) -> np.ndarray:
    """``text`` spoken by espeak-ng (argv, never a shell) as 16 kHz mono int16."""
    wav = subprocess.run(  # noqa: S603 - argv list, text is one argument
        ["espeak-ng", "-v", voice, "-s", str(speed), "--stdout", text],  # noqa: S607 - apt
        capture_output=True,
        check=True,
        timeout=timeout_s,
    ).stdout
    return decode(wav, "audio/wav").pcm


def pink_noise(samples: int, seed: int = 0) -> np.ndarray:
    """Unit-variance pink (1/f) noise."""
    rng = np.random.default_rng(seed)
    spectrum = np.fft.rfft(rng.standard_normal(samples))
    spectrum /= np.sqrt(np.arange(1, spectrum.size + 1))
    noise = np.fft.irfft(spectrum, samples)
    scale = float(np.std(noise)) or 1.0
    return np.asarray(noise / scale, dtype=np.float64)


def with_noise(pcm: np.ndarray, snr_db: float = 10.0, seed: int = 0) -> np.ndarray:
    """``pcm`` with pink noise at ``snr_db`` (speech power over noise power)."""
    signal = pcm.astype(np.float64)
    power = float(np.mean(signal**2)) or 1.0
    noise = pink_noise(signal.size, seed) * np.sqrt(power / 10 ** (snr_db / 10))
    return np.asarray(np.clip(signal + noise, -32768, 32767), dtype=np.int16)


def noise_only(seconds: float, level: float = 3000.0, seed: int = 0) -> np.ndarray:
    """Pink noise alone (nobody speaking), std ``level``."""
    return np.clip(pink_noise(int(seconds * 16000), seed) * level, -32768, 32767).astype(np.int16)
