"""Lazy, offline access to Hugging Face ``transformers`` (the ``[hf]`` extra) and the check of
a local model folder written by ``save_pretrained`` (OWLv2, SAM 2 / SAM 3)."""

from __future__ import annotations

import importlib
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from robot_mcp_perception.models import _torch_env
from robot_mcp_perception.models.base import ModelUnavailableError

HF_HINT = "install the [hf] extra: `uv sync --extra hf` (pip install 'robot-mcp-perception[hf]')"


def import_transformers() -> Any:
    """``transformers``, imported on first use (offline); a clear error when it is absent."""
    _torch_env.prepare()
    try:
        return importlib.import_module("transformers")
    except ImportError as exc:
        raise ModelUnavailableError(f"transformers is not installed; {HF_HINT}") from exc


def checked_model_dir(
    path: str, setting: str, required: Mapping[str, tuple[str, ...]], what: str
) -> Path:
    """The local model folder; a clear error naming the setting and any missing file.

    ``required`` maps each part (e.g. "model weights") to the file names that can hold it;
    ``what`` names the model in messages (e.g. "detector folder")."""
    if not path or not str(path).strip():
        raise ModelUnavailableError(
            f"no {what} configured: set {setting} to a local folder holding the model and its "
            "processor (save_pretrained output)"
        )
    folder = Path(path).expanduser()
    if not folder.is_dir():
        raise ModelUnavailableError(f"{what} {folder} does not exist (set by {setting})")
    for part, names in required.items():
        if not any((folder / name).is_file() for name in names):
            raise ModelUnavailableError(
                f"{what} {folder} (set by {setting}) has no {part}: expected " + " or ".join(names)
            )
    return folder
