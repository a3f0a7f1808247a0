"""A chain of recognizers, like the planner's: the first configured one is used; when it
fails with a named outage (network, timeout, 5xx, 429, auth) the next answers, and the person
is told once per outage, in plain words. The next utterance tries the first again, so the
cloud is used as soon as it is back."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import replace

import structlog

from robot_voice_chat.services.speech.audio import Utterance
from robot_voice_chat.services.speech.base import (
    Heard,
    HearingSpeechInput,
    Outage,
    SpeechInput,
    TranscriptionError,
)

logger = structlog.get_logger(__name__)

OUTAGE_WORDS: dict[Outage, str] = {
    "network": "is unreachable",
    "timeout": "is not answering in time",
    "server": "has a server fault",
    "rate_limit": "is refusing requests for now (rate limit)",
    "auth": "refused my credentials",
}


class SpeechChain(HearingSpeechInput):
    """``providers`` in order of preference; unconfigured ones (no key) are skipped."""

    def __init__(self, providers: Iterable[SpeechInput]) -> None:
        given = list(providers)
        self._providers = [p for p in given if p.configured]
        if not self._providers:
            raise ValueError("speech chain: no configured speech input (give an on-board one last)")
        self._outage: tuple[str, Outage] | None = None  # (provider, outage) being answered for
        self.name = self._providers[0].name
        if len(self._providers) > 1:
            self.name += f", {self._providers[-1].name} when it fails"
        skipped = [p.name for p in given if not p.configured]
        logger.info("speech_chain", providers=[p.name for p in self._providers], skipped=skipped)

    @property
    def providers(self) -> list[SpeechInput]:
        return list(self._providers)

    @property
    def outage(self) -> tuple[str, Outage] | None:
        return self._outage

    def update_vocabulary(
        self, places: Iterable[Iterable[str]], objects: Iterable[str] = (), wake: str = ""
    ) -> bool:
        kept = [list(p) for p in places]
        found = list(objects)
        changed = [p.update_vocabulary(kept, found, wake) for p in self._providers]
        return any(changed)

    async def hear(self, utterance: Utterance) -> Heard:
        notice: str | None = None
        last = len(self._providers) - 1
        for index, provider in enumerate(self._providers):
            try:
                heard = await provider.hear(utterance)
            except TranscriptionError as exc:
                if exc.outage is None or index == last:
                    raise
                notice = notice or self._outage_began(
                    provider, exc.outage, self._providers[index + 1]
                )
                continue
            if index == 0 and self._outage is not None:
                logger.info("speech_provider_back", provider=provider.name)
                self._outage = None
            return replace(heard, notice=notice) if notice else heard
        raise TranscriptionError("no speech input answered")  # pragma: no cover - loop returns

    def _outage_began(
        self, provider: SpeechInput, outage: Outage, instead: SpeechInput
    ) -> str | None:
        logger.warning(
            "speech_provider_outage", provider=provider.name, outage=outage, instead=instead.name
        )
        if self._outage == (provider.name, outage):
            return None  # said once per outage
        self._outage = (provider.name, outage)
        return (
            f"The {provider.name} {OUTAGE_WORDS[outage]}; "
            f"I'm listening with my {instead.name} instead."
        )

    async def aclose(self) -> None:
        for provider in self._providers:
            await provider.aclose()
