"""Lazy access to the optional ``ultralytics`` library (the ``[sam]`` extra)."""

from __future__ import annotations

import hashlib
import importlib
import sys
from pathlib import Path
from typing import Any

import numpy as np
import PIL.Image

from robot_mcp_perception.models import _torch_env
from robot_mcp_perception.models.base import ModelUnavailableError

INSTALL_HINT = (
    "install the [sam] extra: `uv sync --extra sam` (pip install 'robot-mcp-perception[sam]')"
)


def import_ultralytics() -> Any:
    """The ``ultralytics`` module, imported on first use (offline, :mod:`._torch_env`); a
    clear error when it is absent."""
    if "ultralytics" not in sys.modules:
        _torch_env.prepare()
    try:
        module = importlib.import_module("ultralytics")
    except ImportError as exc:
        raise ModelUnavailableError(f"ultralytics is not installed; {INSTALL_HINT}") from exc
    restore_pillow()
    return module


def restore_pillow() -> None:
    """Put Pillow's own ``Image.open`` back after importing ultralytics.

    ultralytics replaces ``PIL.Image.open`` process-wide (``ultralytics.utils.patches``) with
    a wrapper that, on the first file Pillow cannot identify, installs ``pi-heif`` from the
    network and imports it. The node reads its frames with Pillow: one corrupt frame would
    then try a download at run time and, offline, end the frame thread with
    ``ModuleNotFoundError`` instead of skipping the file."""
    patches = sys.modules.get("ultralytics.utils.patches")
    original = getattr(patches, "_image_open", None)
    if original is not None and PIL.Image.open is not original:
        PIL.Image.open = original


def checked_weights(path: str, config_key: str, env_var: str) -> Path:
    """The weights file at ``path``; a clear error naming the config key when it is missing."""
    if not path or not str(path).strip():
        raise ModelUnavailableError(
            f"no weights configured: set {config_key} (or the {env_var} environment variable) "
            "to a local checkpoint file"
        )
    weights = Path(path).expanduser()
    if not weights.is_file():
        raise ModelUnavailableError(
            f"weights file {weights} does not exist (configured by {config_key} / {env_var}); "
            "download the checkpoint and point the setting at it"
        )
    return weights


def to_numpy(value: Any) -> Any:
    """A torch tensor (or anything array-like) as a numpy array."""
    if hasattr(value, "detach"):
        value = value.detach()
    if getattr(value, "is_floating_point", lambda: False)():
        value = value.float()  # bf16 / fp16 results (numpy has no bfloat16)
    if hasattr(value, "cpu"):
        value = value.cpu()
    if hasattr(value, "numpy"):
        return value.numpy()
    return np.asarray(value)


def sam_predictor(model: Any, checkpoint: str, device: str, imgsz: int, half: bool = False) -> Any:
    """The prompt predictor of a loaded ``ultralytics.SAM``, set up on its weights.

    The class is the one the model's ``task_map`` names (SAM, SAM 2 or SAM 3 predictor) and the
    settings are those ``SAM.predict`` uses. Unlike a ``SAM(...)`` call, which encodes the image
    every time, the predictor keeps the embedding of the frame given to ``set_image`` and a
    later ``predictor(bboxes=...)`` / ``predictor(points=..., labels=...)`` runs only the
    prompt decoder on it.
    """
    predictor_class = model.task_map["segment"]["predictor"]
    predictor = predictor_class(
        overrides={
            "model": checkpoint,
            "task": "segment",
            "mode": "predict",
            "conf": 0.25,
            "imgsz": imgsz,
            "device": device,
            "quantize": 16 if half else None,  # ultralytics' half-precision model (CUDA)
            "save": False,
            "verbose": False,
        }
    )
    predictor.setup_model(model=model.model, verbose=False)
    return predictor


def frame_key(image: Any) -> bytes:
    """A digest of a frame's pixels and shape: equal keys, same embedding."""
    digest = hashlib.blake2b(np.ascontiguousarray(image).data, digest_size=16)
    digest.update(repr(image.shape).encode())
    return digest.digest()
