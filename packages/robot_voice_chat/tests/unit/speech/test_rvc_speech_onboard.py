"""The on-board recognizer (issue 36) on speech made at test time with espeak-ng: several
voices and speeds, pink noise. In-vocabulary commands are heard right, negation and correction
too; sentences outside what the robot understands and noise alone are rejected (never a
command); a place added at run time is heard without a restart; and no hypothesis that would
move the robot is acted on unread-back unless it is what was said."""

from __future__ import annotations

import json
import time

import numpy as np
import pytest

from robot_language.scoring import OFFICE_LIST_LOCATIONS
from robot_voice_chat.services.speech.base import Heard
from robot_voice_chat.services.speech.onboard import PocketsphinxSpeechInput
from robot_voice_chat.services.speech.synth import espeak_available, noise_only, say, with_noise
from robot_voice_chat.services.speech.vocabulary import places_from_listing

pytestmark = pytest.mark.skipif(not espeak_available(), reason="espeak-ng is not installed")


@pytest.fixture(scope="module")
def recognizer() -> PocketsphinxSpeechInput:
    engine = PocketsphinxSpeechInput()
    assert engine.update_vocabulary(places_from_listing(OFFICE_LIST_LOCATIONS))
    return engine


def hear(
    recognizer: PocketsphinxSpeechInput, text: str, voice: str, speed: int, noisy: bool
) -> Heard:
    pcm = say(text, voice, speed)
    return recognizer.hear_pcm(with_noise(pcm, 10.0) if noisy else pcm)


# (said, voice, speed, pink noise, heard)
IN_VOCABULARY = [
    ("go to the kitchen", "en-us", 160, False, "go to the kitchen"),
    ("find the scissors in the mailroom", "en-us", 160, True, "find the scissors in the mailroom"),
    ("find the scissors in the mailroom", "en-us", 160, False, "find the scissors in the mailroom"),
    ("what time is it", "en-us", 160, True, "what time is it"),
    ("yes", "en-us", 160, False, "yes"),
    ("stop", "en-us", 140, True, "stop"),
    ("stop", "en-us", 180, True, "stop"),
    ("stop right now", "en-us", 160, False, "stop right now"),
]


@pytest.mark.parametrize(("said", "voice", "speed", "noisy", "heard"), IN_VOCABULARY)
def test_in_vocabulary_speech_is_heard(
    recognizer: PocketsphinxSpeechInput, said: str, voice: str, speed: int, noisy: bool, heard: str
) -> None:
    result = hear(recognizer, said, voice, speed, noisy)
    assert result.usable, result
    assert result.text == heard
    if result.kind != "stop":  # a stop is acted on however unsure (a false stop is safe)
        assert result.confidence is not None
        assert result.confidence >= recognizer.reject_below


@pytest.mark.parametrize("voice", ["en-us", "en-us+f3", "en-029"])
@pytest.mark.parametrize("speed", [160, 170, 180, 190, 200])
def test_a_bare_stop_said_fast_is_a_stop_never_drop_it(
    recognizer: PocketsphinxSpeechInput, voice: str, speed: int
) -> None:
    """The grammar alone heard espeak-ng's "stop" at 160-170 wpm as "drop it" (sure enough to
    be read back as an arm command, never a halt); the stop words now get the last say over a
    hypothesis of a word or two."""
    for noisy in (False, True):
        result = hear(recognizer, "stop", voice, speed, noisy)
        assert result.usable, (noisy, result)
        assert result.kind == "stop", (noisy, result)


def test_negation_and_correction_are_heard_as_said(recognizer: PocketsphinxSpeechInput) -> None:
    negated = hear(recognizer, "don't go to the kitchen", "en-us", 160, False)
    assert negated.text == "don't go to the kitchen"
    assert negated.kind == "other"  # a negation alone moves nothing
    corrected = hear(recognizer, "go to the kitchen, no wait, reception", "en-us", 160, True)
    assert corrected.text == "go to the kitchen no wait reception"
    assert corrected.kind == "motion"


@pytest.mark.parametrize("voice", ["en-us", "en-gb-scotland", "en-us+f3"])
@pytest.mark.parametrize("said", ["the weather is lovely today", "I had a sandwich for lunch"])
def test_out_of_vocabulary_speech_is_no_command(
    recognizer: PocketsphinxSpeechInput, said: str, voice: str
) -> None:
    for noisy in (False, True):
        result = hear(recognizer, said, voice, 160, noisy)
        # rejected, or at most read back as a question: never a command acted on
        assert not result.usable or (result.kind == "motion" and result.confirm), result
        assert not (result.usable and result.kind == "stop")


def test_noise_and_silence_alone_are_rejected(recognizer: PocketsphinxSpeechInput) -> None:
    for seed in range(3):
        assert not recognizer.hear_pcm(noise_only(2.0, seed=seed)).usable
    assert recognizer.hear_pcm(noise_only(1.0, level=20.0)).rejected == "nothing_heard"


def test_a_place_added_at_run_time_is_heard_without_a_restart() -> None:
    engine = PocketsphinxSpeechInput()
    listing = json.loads(OFFICE_LIST_LOCATIONS)
    engine.update_vocabulary(places_from_listing(json.dumps(listing)))
    speech = say("go to the library", "en-us", 160)
    before = engine.hear_pcm(speech)
    assert before.text != "go to the library"
    listing["locations"].append({"name": "library", "description": "Library on the first floor."})
    assert engine.update_vocabulary(places_from_listing(json.dumps(listing)))
    assert not engine.update_vocabulary(places_from_listing(json.dumps(listing)))  # unchanged
    after = engine.hear_pcm(speech)
    assert after.usable, after
    assert after.text == "go to the library"
    assert after.kind == "motion"


def test_a_thing_memory_has_seen_is_heard_once_its_label_arrives() -> None:
    engine = PocketsphinxSpeechInput()
    places = places_from_listing(OFFICE_LIST_LOCATIONS)
    engine.update_vocabulary(places)
    speech = say("find the umbrella", "en-us", 160)
    assert engine.hear_pcm(speech).text != "find the umbrella"
    assert engine.update_vocabulary(places, ["umbrella"])
    after = engine.hear_pcm(speech)
    assert after.usable, after
    assert after.text == "find the umbrella"


SAFETY = [
    ("go to the kitchen", "en-gb-scotland"),
    ("find the scissors in the mailroom", "en-gb-scotland"),
    ("fetch the package from the mailroom and bring it to reception", "en-us"),
    ("fetch the package from the mailroom and bring it to reception", "en-gb-scotland"),
    ("don't go to the kitchen, go to reception", "en-us"),
]


@pytest.mark.parametrize(("said", "voice"), SAFETY)
def test_a_motion_heard_wrong_is_never_acted_on_unasked(
    recognizer: PocketsphinxSpeechInput, said: str, voice: str
) -> None:
    for noisy in (False, True):
        result = hear(recognizer, said, voice, 160, noisy)
        if result.usable and result.kind == "motion" and not result.confirm:
            # acted on without a read-back: only when it is what was said (the verb may be
            # heard as its synonym: "fetch" → "get")
            assert result.text.replace("get ", "fetch ") == said.replace(",", ""), result


def test_a_recording_with_long_silence_around_the_speech_is_heard(
    recognizer: PocketsphinxSpeechInput,
) -> None:
    """A push-to-talk recording: the button held well before and after the sentence (long
    silence shifts the recognizer's cepstral mean; it is cut first)."""
    pcm = say("find the scissors in the mailroom", "en-us", 160)
    silence = np.zeros(int(1.5 * 16000), np.int16)
    result = recognizer.hear_pcm(np.concatenate([silence, pcm, silence, silence]))
    assert result.text == "find the scissors in the mailroom"
    assert result.usable, result


@pytest.mark.parametrize("voice", ["en-gb-scotland", "en-029"])
def test_a_command_heard_right_is_not_rejected_as_unsure(
    recognizer: PocketsphinxSpeechInput, voice: str
) -> None:
    """The fit against the phone loop was measured in two units (the grammar's lattice in the
    decoder's scale, the phone loop shifted 10 bits down, so the loop looked perfect): a
    "go to the kitchen" heard word for word was rejected as unsure (0.07, 0.10)."""
    result = hear(recognizer, "go to the kitchen", voice, 160, False)
    assert result.text == "go to the kitchen"
    assert result.usable, result


def test_hearing_takes_a_small_part_of_the_utterances_own_length(
    recognizer: PocketsphinxSpeechInput,
) -> None:
    """The issue's goal is p50 <= 300 ms for up to 5 s of speech; the word-lattice pass alone
    cost ~450 ms. CPU time of this thread (the decoder runs in it), so a busy machine does
    not make it fail."""
    said = ["go to the kitchen", "fetch the package from the mailroom and bring it to reception"]
    speech = [say(text, "en-us", 160) for text in said]
    recognizer.hear_pcm(speech[0])  # warm
    started = time.thread_time()
    for pcm in speech:
        recognizer.hear_pcm(pcm)
    spent = time.thread_time() - started
    # measured on the 2-core CI machine: 0.11 of the speech's length (0.28 with the lattice)
    assert spent < 0.2 * sum(pcm.size for pcm in speech) / 16000


def test_the_sites_wake_phrase_is_heard_before_a_command() -> None:
    engine = PocketsphinxSpeechInput()
    assert engine.update_vocabulary(places_from_listing(OFFICE_LIST_LOCATIONS), wake="computer")
    heard = engine.hear_pcm(say("computer, go to the kitchen", "en-us", 160))
    assert heard.text == "computer go to the kitchen", heard  # in the grammar, heard as said
    assert heard.kind == "motion"
