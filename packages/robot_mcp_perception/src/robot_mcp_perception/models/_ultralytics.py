"""Lazy access to the optional ``ultralytics`` library (the ``[sam]`` extra)."""

from __future__ import annotations

import importlib
from pathlib import Path
from typing import Any

import numpy as np

from robot_mcp_perception.models.base import ModelUnavailableError

INSTALL_HINT = (
    "install the [sam] extra: `uv sync --extra sam` (pip install 'robot-mcp-perception[sam]')"
)


def import_ultralytics() -> Any:
    """The ``ultralytics`` module, imported on first use; a clear error when it is absent."""
    try:
        return importlib.import_module("ultralytics")
    except ImportError as exc:
        raise ModelUnavailableError(f"ultralytics is not installed; {INSTALL_HINT}") from exc


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
    if hasattr(value, "cpu"):
        value = value.cpu()
    if hasattr(value, "numpy"):
        return value.numpy()
    return np.asarray(value)
