"""Questions and small talk that are answered, never turned into an offer to move (issue 32):
how far / which way to a place, the time, what the robot is doing, how it is, thanks, and
"continue" / "carry on" (which resume a paused mission, and are never a stop). The forms are
data: ``config/questions.yaml``."""

from __future__ import annotations

from dataclasses import dataclass

from robot_language.config_file import CONFIG, Regex, Strict, read_model


class _SmallTalk(Strict):
    pattern: Regex
    reply: str


class QuestionForms(Strict):
    """``config/questions.yaml``: the forms of the questions answered."""

    distance: list[Regex]
    time: Regex
    doing: Regex
    resume: Regex
    small_talk: list[_SmallTalk]
    thanks: Regex
    thanked: Regex
    thanks_ends: Regex


FORMS = read_model(CONFIG / "questions.yaml", QuestionForms, "questions")


@dataclass(frozen=True)
class Asked:
    """A question the robot answers: ``topic`` (distance | time | doing | smalltalk | thanks
    | resume), the place phrase it is about (distance), the sentence that answers it when no
    tool is needed (small talk, thanks)."""

    topic: str
    place: str | None = None
    reply: str = ""


def read_question(text: str) -> Asked | None:
    """``text`` (normalised, one clause) as a question of this module, or None."""
    text = text.strip(" ?!.,")
    if FORMS.time.match(text):
        return Asked("time")
    if FORMS.doing.match(text):
        return Asked("doing")
    if FORMS.resume.match(text):
        return Asked("resume")
    for talk in FORMS.small_talk:
        if talk.pattern.match(text):
            return Asked("smalltalk", reply=talk.reply)
    if FORMS.thanks.match(text) and FORMS.thanked.search(text):
        ends = FORMS.thanks_ends.search(text)
        reply = "You're welcome. I'll be here if you need me." if ends else "You're welcome."
        return Asked("thanks", reply=reply)
    for pattern in FORMS.distance:
        match = pattern.match(text)
        if match is not None:
            return Asked("distance", place=match["place"])
    return None
