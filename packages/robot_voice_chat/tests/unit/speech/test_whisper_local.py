"""The free-form on-board engine (issue 36 item 2) at the port boundary: a fake model object in
place of faster-whisper's, so each rule is shown on segments chosen for it — the confidence
mapping, rejections, the read-back of unsure motion, a stop never refused — and the one-line
refusals of a missing folder, a folder that is no model, and a missing library. The presets
are composed as the brain composes them."""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from robot_voice_chat.composition import ConfigError, build_adapter, compose_config
from robot_voice_chat.services.speech.audio import Utterance
from robot_voice_chat.services.speech.base import TranscriptionError
from robot_voice_chat.services.speech.chain import SpeechChain
from robot_voice_chat.services.speech.onboard import PocketsphinxSpeechInput
from robot_voice_chat.services.speech.synth import espeak_available, say
from robot_voice_chat.services.speech.whisper_local import (
    FasterWhisperSpeechInput,
    confidence_of,
)

SPEECH = Utterance.from_pcm((np.sin(np.arange(16000) / 5.0) * 8000).astype(np.int16))


@dataclass
class Segment:
    text: str
    avg_logprob: float
    no_speech_prob: float = 0.01
    tokens: list[int] = field(default_factory=lambda: [1, 2, 3])


class FakeModel:
    """faster-whisper's ``WhisperModel.transcribe`` shape: (lazy segments, info)."""

    def __init__(self, *segments: Segment) -> None:
        self.segments = segments
        self.calls: list[dict[str, Any]] = []

    def transcribe(self, audio: np.ndarray, **options: Any) -> tuple[Any, None]:
        assert audio.dtype == np.float32
        assert float(np.abs(audio).max()) <= 1.0
        self.calls.append(options)
        return iter(self.segments), None


def engine(*segments: Segment, **settings: Any) -> tuple[FasterWhisperSpeechInput, FakeModel]:
    speech = FasterWhisperSpeechInput(required=False, **settings)
    model = FakeModel(*segments)
    speech._model = model
    return speech, model


def test_confidence_is_the_token_weighted_geometric_mean_token_probability() -> None:
    short = Segment("go to", math.log(0.9), tokens=[1])
    long = Segment("the kitchen", math.log(0.5), tokens=[1, 2, 3])
    confidence, silent = confidence_of([short, long], no_speech_above=0.6)
    assert not silent
    assert confidence == pytest.approx(math.exp((math.log(0.9) + 3 * math.log(0.5)) / 4))
    assert confidence_of([], 0.6) == (0.0, True)
    quiet = Segment("thank you", math.log(0.9), no_speech_prob=0.9)
    assert confidence_of([quiet], 0.6) == (0.0, True)


async def test_a_sure_command_is_acted_on_as_heard_with_the_decoding_options() -> None:
    speech, model = engine(Segment(" Go to the kitchen.", math.log(0.95)))
    speech.update_vocabulary([["kitchen"]])
    heard = await speech.hear(SPEECH)
    assert (heard.text, heard.kind, heard.engine) == ("Go to the kitchen.", "motion", speech.name)
    assert heard.usable
    assert not heard.confirm
    assert heard.confidence == pytest.approx(0.95, abs=1e-3)
    assert model.calls == [
        {
            "language": "en",
            "beam_size": 1,
            "temperature": 0.0,
            "vad_filter": False,
            "condition_on_previous_text": False,
            "without_timestamps": True,
            "hotwords": None,
        }
    ]


async def test_unsure_motion_is_read_back_and_unsure_talk_is_not() -> None:
    speech, _ = engine(Segment("go to the kitchen", math.log(0.5)), confirm_below=0.7)
    speech.update_vocabulary([["kitchen"]])
    heard = await speech.hear(SPEECH)
    assert heard.kind == "motion"
    assert heard.usable
    assert heard.confirm
    chat, _ = engine(Segment("what time is it", math.log(0.5)), confirm_below=0.7)
    said = await chat.hear(SPEECH)
    assert said.kind == "other"
    assert said.usable
    assert not said.confirm


async def test_below_reject_below_is_refused_as_low_confidence() -> None:
    speech, _ = engine(Segment("go to the kitchen", math.log(0.2)), reject_below=0.3)
    heard = await speech.hear(SPEECH)
    assert heard.rejected == "low_confidence"
    assert not heard.usable
    assert not heard.confirm


async def test_a_stop_is_never_refused_however_unsure_or_quiet() -> None:
    speech, _ = engine(Segment("Stop!", math.log(0.05), no_speech_prob=0.9))
    heard = await speech.hear(SPEECH)
    assert (heard.kind, heard.rejected, heard.usable) == ("stop", None, True)


async def test_no_speech_and_empty_text_are_nothing_heard() -> None:
    speech, _ = engine(Segment(" Thank you.", math.log(0.9), no_speech_prob=0.95))
    heard = await speech.hear(SPEECH)
    assert (heard.rejected, heard.confidence) == ("nothing_heard", 0.0)
    empty, _ = engine()
    assert (await empty.hear(SPEECH)).rejected == "nothing_heard"


async def test_silence_is_nothing_heard_without_running_the_model() -> None:
    speech, model = engine(Segment("go home", 0.0))
    heard = await speech.hear(Utterance.from_pcm(np.zeros(16000, np.int16)))
    assert heard.rejected == "nothing_heard"
    assert model.calls == []


async def test_live_names_become_hotwords_only_when_asked_for() -> None:
    plain, plain_model = engine(Segment("hello", 0.0))
    assert plain.update_vocabulary([["reception desk"]], ["stapler"]) is False
    await plain.hear(SPEECH)
    assert plain_model.calls[0]["hotwords"] is None
    prompted, model = engine(Segment("hello", 0.0), prompt_with_vocabulary=True)
    assert prompted.update_vocabulary([["reception desk"]], ["stapler"]) is True
    assert prompted.update_vocabulary([["reception desk"]], ["stapler"]) is False
    await prompted.hear(SPEECH)
    assert "reception desk" in model.calls[0]["hotwords"]
    assert "stapler" in model.calls[0]["hotwords"]


async def test_the_sites_configured_objects_are_hotwords_with_those_heard_of() -> None:
    speech, model = engine(
        Segment("hello", 0.0), prompt_with_vocabulary=True, objects=["defibrillator"]
    )
    assert speech.update_vocabulary([["kitchen"]], ["stapler"]) is True
    await speech.hear(SPEECH)
    hotwords = model.calls[0]["hotwords"]
    assert "defibrillator" in hotwords
    assert "stapler" in hotwords
    assert "scissors" not in hotwords  # the built-in labels only when none are configured


async def test_transcribe_returns_only_usable_text_and_aclose_frees_the_model() -> None:
    speech, _ = engine(Segment("what time is it", math.log(0.9)))
    assert await speech.transcribe(SPEECH.audio, "audio/wav") == "what time is it"
    with pytest.raises(TranscriptionError):
        await speech.transcribe(b"not audio", "audio/wav")
    await speech.aclose()
    with pytest.raises(TranscriptionError, match="no model"):
        await speech.hear(SPEECH)


async def test_a_model_failure_is_a_transcription_error_and_no_outage() -> None:
    class Failing(FakeModel):
        def transcribe(self, audio: np.ndarray, **options: Any) -> tuple[Any, None]:
            raise RuntimeError("out of memory")

    speech, _ = engine()
    speech._model = Failing()
    with pytest.raises(TranscriptionError, match="faster-whisper failed: out of memory") as failed:
        await speech.hear(SPEECH)
    assert failed.value.outage is None  # the audio's own failure: no other engine is tried


def test_the_live_vocabulary_tells_motion_from_talk() -> None:
    speech, _ = engine()
    speech.update_vocabulary([["reception desk", "front desk"]], ["stapler"], wake="robbie")
    assert speech.vocabulary.places == (("reception desk", "front desk"),)
    assert "stapler" in speech.vocabulary.objects
    assert speech.vocabulary.wake == "robbie"


def test_without_a_folder_it_is_unconfigured_or_refuses_in_one_line() -> None:
    assert FasterWhisperSpeechInput(model_dir="", required=False).configured is False
    with pytest.raises(ValueError, match="WHISPER_MODEL is empty"):
        FasterWhisperSpeechInput(model_dir="")


def test_a_missing_folder_or_one_that_is_no_model_is_named(tmp_path: Path) -> None:
    pytest.importorskip("faster_whisper", reason="faster-whisper is not installed")
    with pytest.raises(ValueError, match=f"{tmp_path / 'nowhere'} does not exist"):
        FasterWhisperSpeechInput(model_dir=str(tmp_path / "nowhere"))
    (tmp_path / "model.safetensors").write_bytes(b"")
    with pytest.raises(ValueError, match=r"no model.bin or tokenizer.json .*ct2-transformers"):
        FasterWhisperSpeechInput(model_dir=str(tmp_path))
    (tmp_path / "model.bin").write_bytes(b"not a model")
    (tmp_path / "tokenizer.json").write_text("{}")
    with pytest.raises(ValueError, match=f"cannot load the faster-whisper model in {tmp_path}"):
        FasterWhisperSpeechInput(model_dir=str(tmp_path))


def test_a_missing_library_names_the_extra(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "faster_whisper", None)  # find_spec → None
    with pytest.raises(ValueError, match=r"needs faster-whisper: uv sync --extra whisper"):
        FasterWhisperSpeechInput(model_dir=str(tmp_path))


def test_bad_settings_are_refused() -> None:
    with pytest.raises(ValueError, match="beam_size"):
        FasterWhisperSpeechInput(beam_size=9, required=False)
    with pytest.raises(ValueError, match="compute_type"):
        FasterWhisperSpeechInput(compute_type="int3", required=False)
    with pytest.raises(ValueError, match="reject_below"):
        FasterWhisperSpeechInput(reject_below=0.8, confirm_below=0.5, required=False)


def test_the_whisper_preset_without_a_folder_is_one_config_line(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.delenv("WHISPER_MODEL", raising=False)
    config = compose_config("test", ["speech_input=whisper"])
    with pytest.raises(ConfigError, match="WHISPER_MODEL is empty") as refused:
        build_adapter("speech_input", config.speech_input)
    assert "\n" not in str(refused.value)


@pytest.mark.skipif(not espeak_available(), reason="espeak-ng is not installed")
async def test_whisper_onboard_without_a_folder_hears_with_pocketsphinx(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.delenv("WHISPER_MODEL", raising=False)
    config = compose_config("test", ["speech_input=whisper_onboard"])
    chain = build_adapter("speech_input", config.speech_input)
    assert isinstance(chain, SpeechChain)
    assert [type(p) for p in chain.providers] == [PocketsphinxSpeechInput]
    heard = await chain.hear(Utterance.from_pcm(say("stop")))
    assert (heard.engine, heard.kind) == ("on-board recognizer (pocketsphinx)", "stop")
    await chain.aclose()
