"""Imports of the optional model libraries (transformers, ultralytics) happen offline.

Nothing is fetched at run time: ``HF_HUB_OFFLINE`` / ``TRANSFORMERS_OFFLINE`` (Hugging Face:
``from_pretrained`` reads local files only) and ``YOLO_OFFLINE`` (ultralytics: no online check
at import, no auto-install of a missing package) are set before a library is first imported,
unless the environment already says otherwise; ``HF_HUB_DISABLE_PROGRESS_BARS`` keeps the
loaders' progress bars out of the node's logs.
"""

from __future__ import annotations

import os

OFFLINE_ENV = {
    "HF_HUB_OFFLINE": "1",
    "TRANSFORMERS_OFFLINE": "1",
    "YOLO_OFFLINE": "1",
    "HF_HUB_DISABLE_PROGRESS_BARS": "1",
}


def prepare() -> None:
    """Offline settings, before importing a model library."""
    for key, value in OFFLINE_ENV.items():
        os.environ.setdefault(key, value)
