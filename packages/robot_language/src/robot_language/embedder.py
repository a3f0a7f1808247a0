"""The sentence embedder port and its default adapter: WordLlama's static token embeddings,
loaded from the weights inside its wheel (no download, ever)."""

from __future__ import annotations

import abc
import functools
import time
from pathlib import Path

import numpy as np
import numpy.typing as npt
import structlog

logger = structlog.get_logger(__name__)
Vectors = npt.NDArray[np.float32]


class EmbedderUnavailable(RuntimeError):
    """The embedding model can't be loaded (the reason says what to install)."""


class Embedder(abc.ABC):
    name: str = "embedder"

    @abc.abstractmethod
    def embed(self, texts: list[str]) -> Vectors:
        """One L2-normalised row per text."""


class WordLlamaEmbedder(Embedder):
    """``wordllama`` 0.4.0.post1 (MIT): 256-dim embeddings distilled from LLM token-embedding
    tables, 16 MB of weights shipped in the wheel. ``WordLlama.load()`` would look for the
    tokenizer on the hub, so it is pointed at the package's own folder with downloads off."""

    name = "wordllama"

    def __init__(self) -> None:
        started = time.monotonic()
        try:
            import wordllama  # type: ignore[import-untyped]
            from wordllama import WordLlama
        except ImportError as exc:  # pragma: no cover - a declared dependency
            raise EmbedderUnavailable(
                "the understanding layer needs the wordllama package (uv sync)"
            ) from exc
        try:
            self._model = WordLlama.load(
                cache_dir=Path(wordllama.__file__).parent, disable_download=True
            )
        except Exception as exc:
            raise EmbedderUnavailable(f"can't load the wordllama weights: {exc}") from exc
        duration_ms = round((time.monotonic() - started) * 1000, 1)
        logger.debug("understanding_model_loaded", model=self.name, duration_ms=duration_ms)

    def embed(self, texts: list[str]) -> Vectors:
        vectors = self._model.embed(texts, norm=True)
        return np.asarray(vectors, dtype=np.float32)


@functools.cache
def default_embedder() -> Embedder:
    """One model per process, shared by the rules chat and the rules planner."""
    return WordLlamaEmbedder()
