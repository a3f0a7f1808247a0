"""Cross-package tests that run in one process (no servers started): the helpers beside them
are importable by the tests and by ``benchmarks/`` (pytest runs with --import-mode=importlib)."""

from __future__ import annotations

import sys
from pathlib import Path

HERE = str(Path(__file__).parent)
if HERE not in sys.path:
    sys.path.insert(0, HERE)
