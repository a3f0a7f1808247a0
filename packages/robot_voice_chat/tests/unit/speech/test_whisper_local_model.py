"""The free-form on-board engine against the real faster-whisper and CTranslate2, with a
random-weight Whisper built at test time (as the SAM and OWLv2 adapters are tested): a tiny
``transformers`` Whisper and a byte-level tokenizer with Whisper's special tokens, converted by
CTranslate2's own converter. Its words are noise, so the tests hold what must hold for any
model: a ``Heard`` of the right shape, a confidence in 0..1, noise never acted on, nothing
downloaded.

The libraries come from ``scripts/install-model-libs.sh`` (the brain's ``[whisper]`` extra, and
transformers + torch to build the model). Where they are absent the tests skip saying so —
except in CI (``CI`` set), where their absence fails.
"""

from __future__ import annotations

import importlib.util
import os
import socket
from pathlib import Path
from typing import Any

import pytest

from robot_voice_chat.composition import build_adapter, compose_config
from robot_voice_chat.services.speech.audio import Utterance
from robot_voice_chat.services.speech.chain import SpeechChain
from robot_voice_chat.services.speech.synth import espeak_available, say
from robot_voice_chat.services.speech.whisper_local import FasterWhisperSpeechInput

LIBRARIES = ("faster_whisper", "ctranslate2", "transformers", "torch", "tokenizers")
MISSING = [name for name in LIBRARIES if importlib.util.find_spec(name) is None]
pytestmark = [
    pytest.mark.skipif(
        bool(MISSING) and not os.environ.get("CI"),
        reason=f"{', '.join(MISSING)} not installed: run scripts/install-model-libs.sh",
    ),
    pytest.mark.skipif(not espeak_available(), reason="espeak-ng is not installed"),
]
# Whisper's special tokens, in its order (faster-whisper's Tokenizer looks them up by name);
# English-only: CTranslate2 calls a model multilingual from its vocabulary size
SPECIAL = (
    "<|endoftext|>", "<|startoftranscript|>", "<|en|>", "<|translate|>", "<|transcribe|>",
    "<|startoflm|>", "<|startofprev|>", "<|nocaptions|>", "<|notimestamps|>",
)  # fmt: skip
TIMESTAMPS = 50  # timestamp tokens after <|notimestamps|> (the converter names them)


def build_random_whisper(root: Path) -> Path:
    """A random-weight CTranslate2 Whisper in ``root / "ct2"`` (~1 MB)."""
    import torch
    from ctranslate2.converters import TransformersConverter
    from tokenizers import Tokenizer, decoders, models, pre_tokenizers
    from transformers import (
        PreTrainedTokenizerFast,
        WhisperConfig,
        WhisperForConditionalGeneration,
    )

    vocab = {char: i for i, char in enumerate(sorted(pre_tokenizers.ByteLevel.alphabet()))}
    vocab |= {token: len(vocab) + i for i, token in enumerate(SPECIAL)}
    tokenizer = Tokenizer(models.BPE(vocab=vocab, merges=[]))
    tokenizer.pre_tokenizer = pre_tokenizers.ByteLevel(add_prefix_space=False)
    tokenizer.decoder = decoders.ByteLevel()
    tokenizer.add_special_tokens(list(SPECIAL))
    source, out = root / "hf", root / "ct2"
    end = vocab["<|endoftext|>"]
    PreTrainedTokenizerFast(
        tokenizer_object=tokenizer, eos_token=SPECIAL[0], bos_token=SPECIAL[0], unk_token=SPECIAL[0]
    ).save_pretrained(source)
    config = WhisperConfig(
        vocab_size=len(vocab) + TIMESTAMPS,
        num_mel_bins=80,
        d_model=64,
        encoder_layers=1,
        decoder_layers=1,
        encoder_attention_heads=2,
        decoder_attention_heads=2,
        encoder_ffn_dim=128,
        decoder_ffn_dim=128,
        max_target_positions=448,  # faster-whisper decodes up to 448 tokens
        pad_token_id=end,
        bos_token_id=end,
        eos_token_id=end,
        decoder_start_token_id=vocab["<|startoftranscript|>"],
        suppress_tokens=[],
        begin_suppress_tokens=[end],
    )
    torch.manual_seed(0)
    model = WhisperForConditionalGeneration(config)
    model.generation_config.suppress_tokens = []
    model.generation_config.begin_suppress_tokens = [end]
    model.save_pretrained(source)
    TransformersConverter(str(source)).convert(str(out))
    tokenizer.save(str(out / "tokenizer.json"))
    return out


@pytest.fixture(scope="module")
def model_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return build_random_whisper(tmp_path_factory.mktemp("whisper"))


@pytest.fixture
def offline(monkeypatch: pytest.MonkeyPatch) -> list[str]:
    """Any name lookup (a download's first step) fails and is recorded."""
    attempts: list[str] = []

    def lookup(host: Any, *args: Any, **kwargs: Any) -> Any:
        attempts.append(str(host))
        raise OSError(f"network disabled in this test: lookup of {host!r}")

    monkeypatch.setattr(socket, "getaddrinfo", lookup)
    return attempts


async def test_the_real_library_hears_espeak_and_never_acts_on_noise(
    model_dir: Path, offline: list[str]
) -> None:
    speech = FasterWhisperSpeechInput(model_dir=str(model_dir))
    speech.update_vocabulary([["kitchen"], ["reception desk"]])
    for said in ("go to the kitchen", "stop"):
        heard = await speech.hear(Utterance.from_pcm(say(said)))
        assert heard.engine == "on-board transcription (faster-whisper)"
        assert heard.confidence is not None
        assert 0.0 <= heard.confidence <= 1.0
        # random weights spread the probability over the whole vocabulary: whatever they
        # wrote is far below any threshold, refused, and never a motion read back or done
        assert heard.kind == "stop" or not heard.usable
        assert not heard.confirm
    assert offline == []
    await speech.aclose()


async def test_the_whisper_onboard_preset_uses_the_model_folder_first(
    model_dir: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("WHISPER_MODEL", str(model_dir))
    config = compose_config("test", ["speech_input=whisper_onboard"])
    chain = build_adapter("speech_input", config.speech_input)
    assert isinstance(chain, SpeechChain)
    assert [type(p).__name__ for p in chain.providers] == [
        "FasterWhisperSpeechInput",
        "PocketsphinxSpeechInput",
    ]
    heard = await chain.hear(Utterance.from_pcm(say("what time is it")))
    assert heard.engine == "on-board transcription (faster-whisper)"
    await chain.aclose()


def test_float32_and_a_beam_load_and_decode(model_dir: Path) -> None:
    speech = FasterWhisperSpeechInput(model_dir=str(model_dir), compute_type="float32", beam_size=2)
    heard = speech.hear_pcm(say("bring me the stapler"))
    assert heard.confidence is not None
    assert 0.0 <= heard.confidence <= 1.0
    assert speech.load_s > 0.0
