"""Questions and small talk that are answered, never turned into an offer to move (issue 32):
how far / which way to a place, the time, what the robot is doing, how it is, thanks, and
"continue" / "carry on" (which resume a paused mission, and are never a stop)."""

from __future__ import annotations

import re
from dataclasses import dataclass

_PLACE = r"(?P<place>.+?)"
_HERE = r"(?:\s+(?:from here|from you|away|from where you are|right now|now|exactly))*"
_DISTANCE = [
    re.compile(
        rf"^how (?:far|far away|close|near) (?:are you|am i|is it|is the robot) (?:from|to) "
        rf"{_PLACE}{_HERE}$"
    ),
    re.compile(rf"^how (?:far|far away|close|near) (?:is|are) {_PLACE}{_HERE}$"),
    re.compile(rf"^how many (?:meters|metres|steps) (?:away )?(?:is|to) {_PLACE}{_HERE}$"),
    re.compile(rf"^(?:which|what) (?:way|direction) (?:is|to|for) {_PLACE}{_HERE}$"),
    re.compile(rf"^(?:in )?which direction (?:is|do i go for) {_PLACE}{_HERE}$"),
    re.compile(rf"^(?:is|are) {_PLACE} (?:far|close|near|nearby)(?: away)?{_HERE}$"),
    re.compile(
        r"^how long (?:will|would|does|did|is) (?:it )?(?:take )?(?:you |me |the robot )?"
        rf"(?:take )?(?:to )?(?:get|go|drive|reach|walk|to get|to go)(?: to| over to)? "
        rf"{_PLACE}{_HERE}$"
    ),
    re.compile(rf"^how long (?:to|till|until) (?:get to |reach |you get to )?{_PLACE}{_HERE}$"),
    re.compile(rf"^where(?:'s| is) {_PLACE}(?: from here)?$"),  # only when it is a place
]
_TIME = re.compile(
    r"^(?:(?:do you know|can you tell me|could you tell me|tell me) )?(?:what(?:'s| is) the time"
    r"|what time (?:is it|it is)|the time|got the time|time please|what's the time now)"
    r"(?: now| right now| please)*$"
)
_DOING = re.compile(
    r"^(?:what (?:are|is) (?:you|the robot|it) (?:doing|up to|working on|busy with)"
    r"|what(?:'s| is) (?:your|the robot's) (?:status|current task|task)"
    r"|are you (?:busy|doing anything|working on something)"
    r"|what are you doing)(?: right now| now| at the moment| currently| there)*$"
)
_SMALL_TALK: list[tuple[re.Pattern[str], str]] = [
    (
        re.compile(
            r"^(?:how are you|how are you doing|how's it going|how do you do|how are things|"
            r"what's up|are you ok|are you okay|you ok|you alright|how have you been)"
            r"(?: today| doing| robot| buddy)*$"
        ),
        "I'm fine, thanks: charged and ready for a task.",
    ),
    (
        re.compile(
            r"^(?:good job|well done|nice work|great job|nice one|good robot|good boy|"
            r"you're (?:great|awesome|the best)|nice|great|awesome|perfect|cool)(?: robot)?$"
        ),
        "Thank you!",
    ),
    (re.compile(r"^(?:nice to meet you|pleased to meet you)$"), "Nice to meet you too."),
    (
        re.compile(r"^(?:bye|goodbye|see you|see you later|good night|bye bye)(?: robot)?$"),
        "Goodbye! I'll be here when you need me.",
    ),
]
_THANKS = re.compile(
    r"^(?:(?:ok|okay|great|perfect|awesome|cool|good|fine|right|alright)[\s,]+)*"
    r"(?:thanks|thank you|thank you so much|thanks a lot|thanks so much|many thanks|cheers|"
    r"thanks a bunch|much appreciated|ta)?(?:[\s,]+(?:robot|buddy|mate))?"
    r"(?:[\s,]*(?:that's all|that is all|that'll be all|that will be all|that's it|"
    r"that's everything|nothing else|all good|that's all i need)(?: for now| for today)?)?"
    r"(?:[\s,]+(?:thanks|thank you|cheers))?$"
)
_THANKED = re.compile(r"\b(?:thanks|thank you|cheers|appreciated|that's all|that is all|"
                      r"that'll be all|that will be all|that's it|nothing else)\b")  # fmt: skip
_RESUME = re.compile(
    r"^(?:(?:ok|okay|yes|alright|right|now|so|you can|please|go ahead and)[\s,]+)*"
    r"(?:continue|carry on|go on|keep going|resume|proceed|keep at it|get going again|"
    r"go ahead|start again|restart|unpause|continue on)"
    r"(?:\s+(?:the|your|with the|with your|with)\s+(?:mission|task|job|work|drive|patrol|"
    r"search|plan|what you were doing))?"
    r"(?:\s+(?:now|please|then|again|robot|where you left off))*$"
)


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
    if _TIME.match(text):
        return Asked("time")
    if _DOING.match(text):
        return Asked("doing")
    if _RESUME.match(text):
        return Asked("resume")
    for pattern, reply in _SMALL_TALK:
        if pattern.match(text):
            return Asked("smalltalk", reply=reply)
    if _THANKS.match(text) and _THANKED.search(text):
        ends = re.search(r"\b(?:that's all|that is all|that'll be all|that will be all|"
                         r"that's it|nothing else|that's everything)\b", text)  # fmt: skip
        reply = "You're welcome. I'll be here if you need me." if ends else "You're welcome."
        return Asked("thanks", reply=reply)
    for pattern in _DISTANCE:
        match = pattern.match(text)
        if match is not None:
            return Asked("distance", place=match["place"])
    return None
