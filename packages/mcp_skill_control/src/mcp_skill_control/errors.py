"""The domain error of skill_control (catalog, params, instantiation)."""

from __future__ import annotations


class CatalogError(ValueError):
    """A template or a fill request was rejected; ``code`` is stable, ``detail`` is for humans."""

    def __init__(self, code: str, detail: str) -> None:
        super().__init__(f"{code}: {detail}")
        self.code = code
        self.detail = detail
