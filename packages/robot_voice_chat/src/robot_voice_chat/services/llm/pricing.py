"""Prices (USD per million tokens, from config) → the cost of one model call."""

from __future__ import annotations

from typing import Any

from pydantic import BaseModel, ConfigDict, Field

from robot_voice_chat.services.llm.base import Usage


class Prices(BaseModel):
    model_config = ConfigDict(extra="forbid")

    input: float = Field(ge=0)
    output: float = Field(ge=0)
    cache_read: float = Field(0.0, ge=0)
    cache_write: float = Field(0.0, ge=0)

    @classmethod
    def parse(cls, raw: dict[str, Any] | Prices | None) -> Prices | None:
        if raw is None or isinstance(raw, Prices):
            return raw
        return cls.model_validate(dict(raw))

    def cost(self, usage: Usage) -> float:
        total = (
            usage.input_tokens * self.input
            + usage.output_tokens * self.output
            + usage.cache_read_tokens * self.cache_read
            + usage.cache_write_tokens * self.cache_write
        )
        return round(total / 1_000_000, 8)


def priced(usage: Usage, prices: Prices | None) -> Usage:
    """``usage`` with ``cost_usd`` filled when a price table is configured."""
    return usage if prices is None else usage.model_copy(update={"cost_usd": prices.cost(usage)})
